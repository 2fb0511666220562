//! The explicit scattering orders on the GPU (`gpu::orders`) against their CPU twins
//! (`grid_diffusion`): the cells' first source and gathered orders (`CoarseGrid::new`,
//! `env_grid_sources`, `add_lights`, `sun_sources`, `gather`), the diffusion after them
//! (`explicit_media_radiance`) and the light added per voxel (`add_to_grids`), on the RBF
//! cluster over 15 × 17 × 16 voxels (cells of 2³, those at the edges partly outside,
//! and of one voxel), lit by the built-in sky, a 6° sun and a point
//! light inside the box. Both twins read the same environment grid: the GPU's `S_lm`,
//! read back (the environment pass's own twin test covers it).
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Tolerance.** Everything is marched and summed in `f32` on the GPU, `f64` on the CPU:
//! per ray the transmittance agrees to ~1e-6 and the sums of ≤ 72·30 steps add ~1e-5.
//! What moves more is a march's step count `⌈ℓ/h⌉` where `ℓ/h` is an integer: the cell
//! centers sit at half cells and the rule has latitudes `μ = ±1/2`, so a cell 2.5 cells
//! above the floor reaches it in exactly `ℓ = 5h` along that ring, and rounding takes 5
//! steps on one side and 6 on the other (measured: six rays of one ring in one cell). The
//! midpoint rule over 5 or 6 steps differs by up to 3 % of that ray's transmittance; the
//! ring of 12 rays carries 1/6 of the sphere, so `P` and the cell's moments move by up to
//! `0.03/6 = 5e-3` of their scale (measured on 16³ voxels: ≤ 1.1e-3 in `P`, 2.9e-3 in
//! `L¹`; on these voxels no ray meets it: ≤ 1e-6): held to `|Δ| ≤ 5e-3·max` per
//! quantity. The gather's stop below `T_MIN = 1e-4` moves a ray by
//! at most 1e-4 of its light. The diffusion's `f32` CG stops at the same relative residual
//! 1e-5 as the CPU's `f64` one (the same iteration count, printed); its solution is within
//! `κ·1e-5` relative, κ ≲ 1e2 here, so the final moments and the voxels' light are held to
//! `1e-2·max`.

use haze_gpu::GpuContext;
use haze_view::gpu::GridBuffer;
use haze_view::gpu::env_pass::EnvPass;
use haze_view::gpu::lights_pass::LightsPass;
use haze_view::gpu::orders::{AUTO_FACTOR, CellRadiance, OrdersPass};
use haze_view::render::MsDiffusion;
use haze_view::render::crm::{self, VolumeGrids};
use haze_view::render::env_pass::{EnvGridOptions, directions, grid_frame};
use haze_view::render::grid_diffusion::{
    CoarseGrid, GATHER_LATER_THETA, GridSolveOptions, HIGH, MediaRadiance, add_lights,
    add_to_grids, env_grid_sources, explicit_media_radiance, first_theta, gather, gather_theta,
    scaled_first_sources, sun_sources,
};
use haze_view::sh::{self, ShGrid};
use haze_view::{Environment, Medium, PointLight, Sky, Sources, Sun};

mod common;
use common::{cluster, context, unit_box};

const DIMS: [usize; 3] = [15, 17, 16];
const FACTOR: usize = 2;
const ORDER: usize = 4;
const EYE: [f64; 3] = [0.4, -2.5, 0.7];

fn medium() -> Medium {
    Medium {
        sigma_t: 12.0,
        albedo: 0.9,
        g: 0.4,
    }
}

/// The same medium with HG asymmetry `g`.
fn medium_g(g: f64) -> Medium {
    Medium { g, ..medium() }
}

fn env() -> Environment {
    Environment {
        suns: vec![Sun {
            direction: [0.48, 0.36, 0.8],
            irradiance: [6.0, 5.0, 4.0],
            angle: 6f64.to_radians(),
        }],
        points: vec![PointLight {
            position: [0.31, 0.7, 0.52],
            intensity: [0.2, 0.3, 0.4],
        }],
        ..Environment::sky(Sky::default())
    }
}

/// The cluster's volume-pass grids (no source: the orders add the only light).
fn grids() -> VolumeGrids {
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let source = vec![[vec![0.0], vec![0.0], vec![0.0]]; rbfs.len()];
    crm::volume_pass(&rbfs, &source, 1, DIMS, &bbox, None, EYE)
}

/// What both twins start from: the grid on the GPU, the environment grid (computed on
/// the GPU, read back for the CPU), the CPU's coarse grid, first source and suns.
struct Scene {
    ctx: GpuContext,
    grids: VolumeGrids,
    buf: GridBuffer,
    shadow: haze_view::gpu::env_pass::EnvShadow,
    light: haze_view::lighting::single::RgbSh,
    lights: LightsPass,
    orders: OrdersPass,
    coarse: CoarseGrid,
    sources: Sources,
    suns: Vec<haze_view::render::grid_diffusion::SunSource>,
}

fn scene(env: &Environment, m: &Medium, factor: usize) -> Scene {
    let ctx = context();
    let grids = grids();
    let buf = GridBuffer::upload(&ctx, &grids).unwrap();
    let opts = EnvGridOptions::default();
    let shadow = EnvPass::new(&ctx)
        .unwrap()
        .grid(&ctx, &buf, env, m.sigma_t, ORDER, &opts)
        .unwrap();
    let light = sh::project_env(env, ORDER);
    let sh_grid = ShGrid {
        coeffs: shadow.read(&ctx).unwrap(),
        ..grid_frame(DIMS, &unit_box(), opts.spacing, ORDER)
    };
    let coarse = CoarseGrid::new(&grids.density, factor);
    let mut sources = env_grid_sources(&coarse, &grids.density, &sh_grid, &light, m);
    add_lights(&mut sources, &coarse, &grids.density, env, m, false);
    let suns = sun_sources(&coarse, &grids.density, env, m);
    Scene {
        lights: LightsPass::new(&ctx).unwrap(),
        orders: OrdersPass::new(&ctx).unwrap(),
        ctx,
        grids,
        buf,
        shadow,
        light,
        coarse,
        sources,
        suns,
    }
}

/// The CPU's moments of the cells: `L⁰`, `L¹` and bands 2–4.
struct Moments<'a> {
    l0: &'a [[f64; 3]],
    l1: &'a [[[f64; 3]; 3]],
    high: &'a [[[f64; HIGH]; 3]],
}

/// The worst `|Δ|/max` of `L⁰`, `L¹`, the escape probability and bands 2–4 between the
/// GPU's cells and the CPU's, after checking the coarse density.
fn differences(
    gpu: &CellRadiance,
    cpu: Moments<'_>,
    escape: Option<&[f64]>,
    coarse: &CoarseGrid,
) -> [f64; 4] {
    let Moments { l0, l1, high } = cpu;
    assert_eq!(gpu.cells, coarse.dims);
    for (a, b) in gpu.density.iter().zip(&coarse.density) {
        assert!(
            (a - b).abs() <= 1e-5 * b.abs().max(1e-3),
            "density {a} vs {b}"
        );
    }
    let max0 = l0.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let max1 = l1
        .iter()
        .flatten()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(max0 > 0.0 && max1 > 0.0, "no light gathered");
    let d0 = gpu
        .l0
        .iter()
        .flatten()
        .zip(l0.iter().flatten())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    let d1 = gpu
        .l1
        .iter()
        .flatten()
        .flatten()
        .zip(l1.iter().flatten().flatten())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    let de = escape.map_or(0.0, |e| {
        gpu.escape
            .iter()
            .zip(e)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
    });
    let maxh = high
        .iter()
        .flatten()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(maxh > 0.0, "no bands 2–4 gathered");
    let dh = gpu
        .high
        .iter()
        .flatten()
        .flatten()
        .zip(high.iter().flatten().flatten())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    [d0 / max0, d1 / max1, de, dh / maxh]
}

/// The next order's source `Ω (L⁰ + g L¹·ω)` of gathered light (`grid_diffusion`'s).
fn scattered(l0: &[[f64; 3]], l1: &[[[f64; 3]; 3]], m: &Medium) -> Sources {
    Sources {
        j0: l0.iter().map(|c| c.map(|v| m.albedo * v)).collect(),
        j1: l1
            .iter()
            .map(|c| c.map(|a| a.map(|v| m.albedo * m.g * v)))
            .collect(),
        escape: Vec::new(),
    }
}

#[test]
fn gathered_orders_match_the_cpu() {
    // Cells of 2³ voxels, and of one voxel, where a ray takes up to 28 steps: the
    // longest loops an invocation runs here (lavapipe cuts them short past a budget,
    // shaders/orders.wgsl).
    // At g 0.8 the first order takes `gather_theta`'s finer rule (128 directions, 16
    // dispatches); at a lighting detail of 0.43 and g 0.4 the later orders' 32
    // (`first_theta`).
    for (factor, g, detail) in [
        (FACTOR, 0.4, 1.0),
        (1, 0.4, 1.0),
        (FACTOR, 0.8, 1.0),
        (FACTOR, 0.4, 0.43),
    ] {
        gathered_orders_match(factor, g, detail);
    }
}

fn gathered_orders_match(factor: usize, g: f64, detail: f64) {
    let (env, m) = (env(), medium_g(g));
    let s = scene(&env, &m, factor);
    let first: Vec<_> = directions(first_theta(m.g, detail)).points().collect();
    let later: Vec<_> = directions(GATHER_LATER_THETA).points().collect();
    // The CPU's first and second orders, summed, through the delta-Eddington transport
    // medium `t` with the first source scaled by `k` (as `explicit_media_radiance`).
    let (t, k) = m.delta_eddington();
    assert!(k > 1.0, "the test's medium has no forward peak");
    let (sources, suns) = scaled_first_sources(&s.sources, &s.suns, k);
    let g1 = gather(&s.coarse, t.sigma_t, &sources, &suns, &first);
    let g2 = gather(
        &s.coarse,
        t.sigma_t,
        &scattered(&g1.l0, &g1.l1, &t),
        &[],
        &later,
    );
    let mut l0 = g1.l0.clone();
    let mut l1 = g1.l1.clone();
    let mut high = g1.high.clone();
    for (i, ((a, b), h)) in g2.l0.iter().zip(&g2.l1).zip(&g2.high).enumerate() {
        for c in 0..3 {
            l0[i][c] += a[c];
            (0..3).for_each(|k| l1[i][c][k] += b[c][k]);
            (0..HIGH).for_each(|k| high[i][c][k] += h[c][k]);
        }
    }
    let one = Moments {
        l0: &g1.l0,
        l1: &g1.l1,
        high: &g1.high,
    };
    let two = Moments {
        l0: &l0,
        l1: &l1,
        high: &high,
    };
    for (orders, cpu) in [(1, one), (2, two)] {
        let media = s
            .orders
            .gather(
                &s.ctx, &s.buf, &s.shadow, &s.light, &env, &s.lights, &m, factor, orders, detail,
            )
            .unwrap();
        let gpu = media.read(&s.ctx).unwrap();
        let d = differences(&gpu, cpu, Some(&g1.escape), &s.coarse);
        print!("cells of {factor}³, g {g}, detail {detail}: ");
        println!(
            "{orders} order(s): |ΔL⁰|/max {:.2e}, |ΔL¹|/max {:.2e}, |ΔP| {:.2e}, |Δc_lm|/max {:.2e}",
            d[0], d[1], d[2], d[3]
        );
        assert!(d.iter().all(|&v| v <= 5e-3), "{orders} orders: {d:?}");
    }
}

#[test]
fn the_diffusion_after_the_orders_and_the_voxels_match_the_cpu() {
    let (env, m) = (env(), medium());
    let s = scene(&env, &m, FACTOR);
    let first: Vec<_> = directions(gather_theta(m.g)).points().collect();
    let later: Vec<_> = directions(GATHER_LATER_THETA).points().collect();
    let opts = GridSolveOptions::default();
    let orders = 2;
    let cpu: MediaRadiance = explicit_media_radiance(
        s.coarse.clone(),
        &m,
        &s.sources,
        &s.suns,
        orders,
        &first,
        &later,
        &opts,
    );
    assert!(cpu.iterations > 0, "the CPU solved nothing");
    let media = s
        .orders
        .gather(
            &s.ctx, &s.buf, &s.shadow, &s.light, &env, &s.lights, &m, FACTOR, orders, 1.0,
        )
        .unwrap();
    s.orders
        .diffuse(&s.ctx, &s.buf, &s.shadow, &media, &opts)
        .unwrap();
    let gpu = media.read(&s.ctx).unwrap();
    let solve = s.orders.solve_stats(&s.ctx).unwrap().unwrap();
    println!(
        "CG: CPU {} iterations (residual {:.1e}), GPU {} ({:.1e})",
        cpu.iterations, cpu.residual, solve.iterations, solve.residual
    );
    assert!(solve.iterations > 0 && solve.residual <= opts.tolerance);
    let moments = Moments {
        l0: &cpu.l0,
        l1: &cpu.l1,
        high: &cpu.high,
    };
    let d = differences(&gpu, moments, None, &s.coarse);
    println!(
        "final: |ΔL⁰|/max {:.2e}, |ΔL¹|/max {:.2e}, |Δc_lm|/max {:.2e}",
        d[0], d[1], d[3]
    );
    assert!(d[0] <= 1e-2 && d[1] <= 1e-2 && d[3] <= 1e-2, "{d:?}");

    // Per voxel, towards the eye.
    let mut want = s.grids.clone();
    add_to_grids(&mut want, &cpu, &m, EYE);
    s.orders
        .apply(&s.ctx, &s.buf, &s.shadow, &media, EYE)
        .unwrap();
    let got = s.buf.read(&s.ctx).unwrap();
    let jmax = want
        .radiance
        .iter()
        .flatten()
        .fold(0.0f64, |a, v| a.max(f64::from(*v)));
    assert!(jmax > 0.0);
    let dj = want
        .radiance
        .iter()
        .flatten()
        .zip(got.radiance.iter().flatten())
        .fold(0.0f64, |a, (x, y)| a.max(f64::from((x - y).abs())));
    println!("per voxel: |ΔJ|/max {:.2e}", dj / jmax);
    assert!(dj <= 1e-2 * jmax, "{}", dj / jmax);
    // The peak's share left to the eye's ray: Ωf, `f32` against `f64`.
    assert!(want.eye_peak > 0.0);
    assert!(
        (got.eye_peak - want.eye_peak).abs() <= 1e-6,
        "{} vs {}",
        got.eye_peak,
        want.eye_peak
    );
}

#[test]
fn extremes_add_nothing_or_are_refused() {
    let env = env();
    let s = scene(&env, &medium(), FACTOR);
    // Albedo 0 and σt 0: nothing scatters, the grid is untouched.
    for m in [
        Medium {
            albedo: 0.0,
            ..medium()
        },
        Medium {
            sigma_t: 0.0,
            ..medium()
        },
    ] {
        s.orders
            .run_on(
                &s.ctx,
                &s.buf,
                &s.shadow,
                &s.light,
                &env,
                &s.lights,
                &m,
                EYE,
                (FACTOR, 2),
                &GridSolveOptions::default(),
            )
            .unwrap();
        let got = s.buf.read(&s.ctx).unwrap();
        assert_eq!(got.radiance, s.grids.radiance, "{m:?}");
    }
    // Opaque smoke: finite and non-negative everywhere.
    let thick = Medium {
        sigma_t: 1e4,
        ..medium()
    };
    let media = s
        .orders
        .gather(
            &s.ctx, &s.buf, &s.shadow, &s.light, &env, &s.lights, &thick, FACTOR, 3, 1.0,
        )
        .unwrap();
    s.orders
        .diffuse(
            &s.ctx,
            &s.buf,
            &s.shadow,
            &media,
            &GridSolveOptions::default(),
        )
        .unwrap();
    let cells = media.read(&s.ctx).unwrap();
    assert!(
        cells
            .l0
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0)
    );
    assert!(cells.l1.iter().flatten().flatten().all(|v| v.is_finite()));
    // Bad input.
    let m = medium();
    let run = |factor, orders, env: &Environment| {
        s.orders
            .gather(
                &s.ctx, &s.buf, &s.shadow, &s.light, env, &s.lights, &m, factor, orders, 1.0,
            )
            .map(|_| ())
            .unwrap_err()
            .to_string()
    };
    // The automatic factor is the GPU's.
    let auto = s
        .orders
        .gather(
            &s.ctx,
            &s.buf,
            &s.shadow,
            &s.light,
            &env,
            &s.lights,
            &m,
            MsDiffusion::AUTO,
            2,
            1.0,
        )
        .unwrap();
    let cells = auto.read(&s.ctx).unwrap().cells;
    assert_eq!(cells, DIMS.map(|n| n.div_ceil(AUTO_FACTOR)));
    assert!(run(9, 2, &env).contains("1 to 8"));
    assert!(run(2, 9, &env).contains("orders"));
    let mut many = env.clone();
    many.suns = vec![env.suns[0].clone(); 9];
    assert!(run(2, 2, &many).contains("at most 8"));
    let small = GridBuffer::upload(&s.ctx, &{
        let bbox = unit_box();
        let rbfs = cluster(&bbox);
        let source = vec![[vec![0.0], vec![0.0], vec![0.0]]; rbfs.len()];
        crm::volume_pass(&rbfs, &source, 1, [8, 8, 8], &bbox, None, EYE)
    })
    .unwrap();
    let e = s
        .orders
        .gather(
            &s.ctx, &small, &s.shadow, &s.light, &env, &s.lights, &m, FACTOR, 2, 1.0,
        )
        .map(|_| ())
        .unwrap_err();
    assert!(e.to_string().contains("another volume grid"), "{e}");
}

/// The cells' `L⁰` after the orders and the diffusion of `env` on `pass` (solved from
/// where its last solve ended, if any), with the CG's iterations.
fn solved(s: &Scene, pass: &OrdersPass, env: &Environment) -> (Vec<[f64; 3]>, u32) {
    let m = medium();
    let media = pass
        .gather(
            &s.ctx, &s.buf, &s.shadow, &s.light, env, &s.lights, &m, FACTOR, 2, 1.0,
        )
        .unwrap();
    pass.diffuse(
        &s.ctx,
        &s.buf,
        &s.shadow,
        &media,
        &GridSolveOptions::default(),
    )
    .unwrap();
    let iterations = pass.solve_stats(&s.ctx).unwrap().unwrap().iterations;
    (media.read(&s.ctx).unwrap().l0, iterations)
}

/// Playback's warm start: a solve that starts from the last one's solution ends where a
/// solve from zero does (both at the relative residual 1e-5, so within `κ·1e-5`, held to
/// 1e-3 of the largest `L⁰` as the twin test's 1e-2 is for `f32` against `f64`), in fewer
/// iterations; the same frame again needs next to none; `reset` makes it cold again.
#[test]
fn a_warm_start_ends_where_a_cold_one_does() {
    let env0 = env();
    let s = scene(&env0, &medium(), FACTOR);
    // The next frame's light: the sun and the lamp a little brighter, the lamp moved.
    let mut env1 = env0.clone();
    env1.suns[0].irradiance = [6.6, 5.4, 4.5];
    env1.points[0].intensity = [0.25, 0.33, 0.42];
    env1.points[0].position = [0.35, 0.66, 0.55];
    let fresh = OrdersPass::new(&s.ctx).unwrap();
    let (cold, cold_iterations) = solved(&s, &fresh, &env1);

    let (_, first) = solved(&s, &s.orders, &env0);
    let (warm, warm_iterations) = solved(&s, &s.orders, &env1);
    let max = cold.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let d = cold
        .iter()
        .flatten()
        .zip(warm.iter().flatten())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    println!(
        "cold {cold_iterations} iterations ({first} for the frame before), warm \
         {warm_iterations}; |ΔL⁰|/max {:.2e}",
        d / max
    );
    assert!(max > 0.0 && d <= 1e-3 * max, "{}", d / max);
    assert!(
        warm_iterations < cold_iterations,
        "{warm_iterations} vs {cold_iterations}"
    );

    let (_, again) = solved(&s, &s.orders, &env1);
    assert!(again <= cold_iterations / 4, "{again} vs {cold_iterations}");
    s.orders.reset();
    let (_, after_reset) = solved(&s, &s.orders, &env1);
    assert_eq!(after_reset, cold_iterations);
}

/// The batches' ends: no iterations allowed ends at once with nothing solved, a cap
/// below convergence (37 iterations here) stops at exactly the cap with the residual
/// still above the tolerance, and the cells' light stays finite either way.
#[test]
fn the_cg_stops_at_its_most_iterations() {
    let env = env();
    let m = medium();
    let s = scene(&env, &m, FACTOR);
    for max in [0, 1, 5] {
        let pass = OrdersPass::new(&s.ctx).unwrap();
        let media = pass
            .gather(
                &s.ctx, &s.buf, &s.shadow, &s.light, &env, &s.lights, &m, FACTOR, 2, 1.0,
            )
            .unwrap();
        let opts = GridSolveOptions {
            max_iterations: max,
            ..GridSolveOptions::default()
        };
        pass.diffuse(&s.ctx, &s.buf, &s.shadow, &media, &opts)
            .unwrap();
        let solve = pass.solve_stats(&s.ctx).unwrap().unwrap();
        assert_eq!(solve.iterations, max);
        if max > 0 {
            assert!(solve.residual > opts.tolerance, "{max}: {}", solve.residual);
        }
        let l0 = media.read(&s.ctx).unwrap().l0;
        assert!(l0.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    }
}
