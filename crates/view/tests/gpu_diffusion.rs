//! Multiple scattering on the GPU (`gpu::diffusion`) against its CPU twin
//! `render::add_multiple_scattering` (`f64` assembly, CGLS and `J̃ms`): the solution `L⁰`
//! and the sources with `J̃ms` added, from the same single-scattering sources (the GPU's,
//! read back, so both start from the same numbers). Small and larger-than-a-workgroup
//! sets, SH orders 1, 2 and 4, anisotropic and isotropic phase, and the extremes (σt = 0,
//! albedo 1, inactive RBFs, no RBFs), the warm start, a mismatched buffer, and the direct
//! light of suns and point lights added to the source (`gpu::diffusion::DirectBuffer`,
//! the CPU's `lighting::direct::add_light_moments`).
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Tolerance.** The GPU solves in `f32` (ε = 1.2e-7) what the CPU solves in `f64` to
//! `1e-6`. A backward-stable solve of the equilibrated system `M = R A C` leaves a relative
//! error of `y = C⁻¹ L⁰` of about `c·ε·κ(M)`, with `c` the rounding of one product `M y`
//! (tens of terms per row) and of the `f32` inputs (operators, sources); `κ(M)` is
//! computed here by SVD. Measured (printed with `--nocapture`): `‖ΔL⁰‖/‖L⁰‖` ≤ 1.7e-7 at
//! `κ ≤ 4` (1.5 ε) and 5.9e-7 at `κ = 70` (0.07 εκ), the sources with `J̃ms` below that.
//! The tests take `tol = 20·ε·(1 + κ)` — 50× the worst measured — for `L⁰` per channel,
//! and for the sources per center relative to the largest source.

use haze_gpu::GpuContext;
use haze_view::diffusion::{Operators, SolveOptions, Sources, solve_system};
use haze_view::gpu::diffusion::{DiffusionPass, DirectBuffer, OperatorBuffers};
use haze_view::gpu::single_scattering::SingleScatteringPass;
use haze_view::lighting::direct::add_light_moments;
use haze_view::lighting::single::moments;
use haze_view::lighting::single::{ShKit, SourcePoints};
use haze_view::render::{CrmOptions, CrmStats, add_multiple_scattering};
use haze_view::sh::{self, ExpMethod};
use haze_view::{DiffusionSolver, Environment, Medium, PointLight, Sky, Sun};
use haze_volume::Rbf;
use nalgebra::DMatrix;

mod common;
use common::{context, unit_box};

/// `n` RBFs scattered by a fixed linear congruential sequence in the unit cube, with
/// radii that make them overlap.
fn scattered(n: usize, seed: u64) -> Vec<Rbf> {
    let mut s: u64 = 0x9e37_79b9_7f4a_7c15 ^ seed;
    let mut next = || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let spread = (n as f64).cbrt();
    (0..n)
        .map(|_| {
            let c = [next(), next(), next()];
            Rbf::new(c, (0.12 + 0.1 * next()) / spread, 0.2 + next())
        })
        .collect()
}

/// The single-scattering sources of `rbfs` on the GPU (the stage before the diffusion).
fn single(
    ctx: &GpuContext,
    rbfs: &[Rbf],
    medium: &Medium,
    order: usize,
) -> haze_view::gpu::SourceBuffer {
    let kit = ShKit::new(order);
    let light = sh::project_env(&Environment::sky(Sky::default()), order);
    SingleScatteringPass::new(ctx, &kit)
        .unwrap()
        .run(
            ctx,
            &kit,
            rbfs,
            medium,
            &light,
            ExpMethod::ScaleSquareAuto,
            SourcePoints::Footprint,
        )
        .unwrap()
}

/// `κ(R A C)` of the system the CPU's CGLS iterates on (row- then column-equilibrated).
fn condition(ops: &Operators, medium: &Medium, sources: &Sources) -> f64 {
    let a: DMatrix<f64> = ops.system(medium, sources).a.to_dense();
    let n = a.nrows();
    let mut m = a.clone();
    for h in 0..n {
        let norm = m.row(h).norm();
        if norm > 0.0 {
            m.row_mut(h).scale_mut(1.0 / norm);
        }
    }
    for l in 0..n {
        let norm = m.column(l).norm();
        if norm > 0.0 {
            m.column_mut(l).scale_mut(1.0 / norm);
        }
    }
    let sv = m.singular_values();
    sv.max() / sv.min()
}

/// Runs the GPU diffusion on the single scattering of `rbfs` and compares it with the
/// CPU's; returns the relative error of `L⁰` and of the sources.
fn check(ctx: &GpuContext, rbfs: &[Rbf], medium: &Medium, order: usize, what: &str) -> (f64, f64) {
    check_lit(
        ctx,
        rbfs,
        medium,
        &Environment::constant([0.0; 3]),
        order,
        what,
    )
    .0
}

/// [`check`] with the direct light of `env`'s suns and point lights in the source (the
/// single scattering stays the sky's); also returns the CPU's sources with `J̃ms`.
fn check_lit(
    ctx: &GpuContext,
    rbfs: &[Rbf],
    medium: &Medium,
    env: &Environment,
    order: usize,
    what: &str,
) -> ((f64, f64), Vec<haze_view::lighting::single::RgbSh>) {
    let buffer = single(ctx, rbfs, medium, order);
    let ss = buffer.read(ctx).unwrap();
    let opts = CrmOptions {
        order,
        ..CrmOptions::default()
    };
    // CPU: the solution and the sources with J̃ms.
    let ops = Operators::new(rbfs);
    let mut sources = Sources {
        escape: ss.escape.clone(),
        ..moments(&ss.source)
    };
    add_light_moments(&mut sources, rbfs, env, medium);
    let cpu_l0 = solve_system(
        &ops.system(medium, &sources),
        &vec![[0.0; 3]; rbfs.len()],
        &opts.solve,
    );
    assert!(cpu_l0.converged, "{what}: CPU solve {cpu_l0:?}");
    let mut cpu = ss.source.clone();
    add_multiple_scattering(
        rbfs,
        medium,
        env,
        &mut cpu,
        ss.escape.clone(),
        &opts,
        &mut DiffusionSolver::new(),
        &mut CrmStats::default(),
    );
    // GPU.
    let mut pass = DiffusionPass::new(ctx).unwrap();
    let gpu_ops = OperatorBuffers::upload(ctx, &ops).unwrap();
    let direct = env.has_lights().then(|| {
        let mut m = Sources::zeros(rbfs.len());
        add_light_moments(&mut m, rbfs, env, medium);
        DirectBuffer::upload(ctx, &m).unwrap()
    });
    pass.run_with(ctx, &gpu_ops, medium, &buffer, direct.as_ref(), &opts.solve)
        .unwrap();
    let gpu = buffer.read(ctx).unwrap();
    let stats = pass.stats(ctx).unwrap().unwrap();
    let gpu_l0 = pass.solution(ctx).unwrap().unwrap();

    let kappa = condition(&ops, medium, &sources);
    let tol = 20.0 * f64::from(f32::EPSILON) * (1.0 + kappa);
    let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|x| x * x).sum::<f64>().sqrt();
    let l0_err = (0..3)
        .map(|c| {
            let diff = norm(&mut gpu_l0.iter().zip(&cpu_l0.l0).map(|(g, r)| g[c] - r[c]));
            let scale = norm(&mut cpu_l0.l0.iter().map(|r| r[c]));
            if scale > 0.0 { diff / scale } else { diff }
        })
        .fold(0.0, f64::max);
    let largest = cpu
        .iter()
        .map(|j| j.iter().flatten().map(|v| v * v).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    let mut src_err: f64 = 0.0;
    for (h, (g, c)) in gpu.source.iter().zip(&cpu).enumerate() {
        let diff = (0..3)
            .flat_map(|ch| g[ch].iter().zip(&c[ch]).map(|(a, b)| (a - b).powi(2)))
            .sum::<f64>()
            .sqrt();
        src_err = src_err.max(diff / largest.max(1e-30));
        assert!(
            diff <= tol * largest + 1e-12,
            "{what}: center {h}: GPU {g:?}, CPU {c:?} (tol {tol:.1e})"
        );
    }
    // The escape probabilities are left as single scattering wrote them.
    assert_eq!(gpu.escape, ss.escape, "{what}");
    println!(
        "{what}: {} RBFs, κ(RAC) {kappa:.0}, {} GPU iterations (CPU {}), L⁰ {l0_err:.1e}, \
         sources {src_err:.1e} (tol {tol:.1e})",
        rbfs.len(),
        stats.iterations,
        cpu_l0.iterations
    );
    assert!(stats.converged, "{what}: {stats:?}");
    assert!(l0_err <= tol, "{what}: L⁰ error {l0_err:.2e} > {tol:.2e}");
    ((l0_err, src_err), cpu)
}

#[test]
fn lights_in_the_source_match_the_cpu() {
    // A sun and a point light (outside the cluster and inside it) add their direct light
    // at the centers to the diffusion's source: J⁰ in b, J¹ in b and in J̃ms's band 1.
    let ctx = context();
    let cluster = common::cluster(&unit_box());
    let mut env = Environment::constant([0.0; 3]);
    env.suns.push(Sun {
        direction: [0.36, 0.48, 0.8],
        irradiance: [8.0, 7.0, 6.0],
        angle: 0.53f64.to_radians(),
    });
    env.points
        .push(PointLight::new([1.3, 0.2, 0.7], [2.0, 1.5, 1.0]).unwrap());
    env.points
        .push(PointLight::new([0.5, 0.5, 0.5], [0.05, 0.05, 0.05]).unwrap());
    let dark = Environment::constant([0.0; 3]);
    for (medium, order, what) in [
        (
            Medium::new(8.0, 0.9, 0.6).unwrap(),
            4,
            "lit, g 0.6, order 4",
        ),
        (Medium::new(8.0, 0.9, 0.0).unwrap(), 2, "lit, g 0, order 2"),
        (
            Medium::new(8.0, 0.9, -0.4).unwrap(),
            1,
            "lit, g −0.4, order 1",
        ),
    ] {
        let (_, lit) = check_lit(&ctx, &cluster, &medium, &env, order, what);
        // The lights matter: the sources without them are far outside the tolerance.
        let (_, unlit) = check_lit(&ctx, &cluster, &medium, &dark, order, "unlit");
        let largest = lit
            .iter()
            .map(|j| j.iter().flatten().map(|v| v * v).sum::<f64>().sqrt())
            .fold(0.0, f64::max);
        let change = lit
            .iter()
            .zip(&unlit)
            .flat_map(|(a, b)| {
                (0..3).flat_map(move |c| a[c].iter().zip(&b[c]).map(|(x, y)| (x - y).abs()))
            })
            .fold(0.0, f64::max);
        assert!(
            change > 0.1 * largest,
            "{what}: the lights changed J̃ by {change}"
        );
    }
    // Moments for another set: refused.
    let medium = Medium::new(8.0, 0.9, 0.6).unwrap();
    let buffer = single(&ctx, &cluster, &medium, 2);
    let ops = OperatorBuffers::upload(&ctx, &Operators::new(&cluster)).unwrap();
    let direct = DirectBuffer::upload(&ctx, &Sources::zeros(2)).unwrap();
    let e = DiffusionPass::new(&ctx)
        .unwrap()
        .run_with(
            &ctx,
            &ops,
            &medium,
            &buffer,
            Some(&direct),
            &SolveOptions::default(),
        )
        .unwrap_err();
    assert!(e.to_string().contains("direct light for 2 centers"), "{e}");
}

#[test]
fn matches_the_cpu_on_small_and_large_sets() {
    let ctx = context();
    let medium = Medium::new(8.0, 0.9, 0.3).unwrap();
    let cluster = common::cluster(&unit_box());
    check(&ctx, &cluster, &medium, 4, "cluster, order 4");
    check(&ctx, &cluster, &medium, 1, "cluster, order 1");
    let isotropic = Medium::new(8.0, 0.9, 0.0).unwrap();
    check(&ctx, &cluster, &isotropic, 2, "cluster, g = 0");
    // More centers than the workgroup has invocations (256): the strided loops; and
    // ~200 iterations, carried across a dozen `iterate` dispatches.
    check(&ctx, &scattered(300, 1), &medium, 2, "300 scattered");
}

#[test]
fn extremes_stay_finite_and_match() {
    let ctx = context();
    let cluster = common::cluster(&unit_box());
    // Albedo 1: no absorption, only the vacuum correction's sink.
    check(
        &ctx,
        &cluster,
        &Medium::new(8.0, 1.0, 0.5).unwrap(),
        2,
        "albedo 1",
    );
    // Thick smoke.
    check(
        &ctx,
        &cluster,
        &Medium::new(300.0, 0.8, 0.2).unwrap(),
        2,
        "σt = 300",
    );
    // Inactive RBFs among active ones: identity rows, no coupling.
    let mut mixed = cluster.clone();
    mixed.push(Rbf::new([0.5; 3], 0.1, 0.0));
    mixed.push(Rbf::new([0.45, 0.5, 0.5], 0.0, 1.0));
    mixed.push(Rbf::new([0.5, 0.52, 0.5], 0.1, -2.0));
    check(
        &ctx,
        &mixed,
        &Medium::new(8.0, 0.9, 0.3).unwrap(),
        2,
        "inactive RBFs",
    );

    // σt = 0: no extinction, no source; the sources stay as they were.
    let medium = Medium::new(0.0, 0.9, 0.3).unwrap();
    let buffer = single(&ctx, &cluster, &medium, 2);
    let before = buffer.read(&ctx).unwrap();
    let mut pass = DiffusionPass::new(&ctx).unwrap();
    let ops = OperatorBuffers::upload(&ctx, &Operators::new(&cluster)).unwrap();
    pass.run(&ctx, &ops, &medium, &buffer, &SolveOptions::default())
        .unwrap();
    let after = buffer.read(&ctx).unwrap();
    assert_eq!((after.source, after.escape), (before.source, before.escape));

    // No RBFs: nothing to do, no error.
    let empty = single(&ctx, &[], &medium, 2);
    let ops = OperatorBuffers::upload(&ctx, &Operators::new(&[])).unwrap();
    pass.run(
        &ctx,
        &ops,
        &Medium::new(8.0, 0.9, 0.3).unwrap(),
        &empty,
        &SolveOptions::default(),
    )
    .unwrap();

    // Sources for another set: refused.
    let other = single(&ctx, &cluster[..3], &medium, 2);
    let ops = OperatorBuffers::upload(&ctx, &Operators::new(&cluster)).unwrap();
    let e = pass
        .run(
            &ctx,
            &ops,
            &Medium::new(8.0, 0.9, 0.3).unwrap(),
            &other,
            &SolveOptions::default(),
        )
        .unwrap_err();
    assert!(e.to_string().contains("3 centers"), "{e}");
}

#[test]
fn starts_from_the_last_solution() {
    let ctx = context();
    // 300 RBFs: ~200 iterations from zero at 1e-6.
    let rbfs = scattered(300, 1);
    let medium = Medium::new(8.0, 0.9, 0.3).unwrap();
    let ops = OperatorBuffers::upload(&ctx, &Operators::new(&rbfs)).unwrap();
    let mut pass = DiffusionPass::new(&ctx).unwrap();
    let solve = SolveOptions::default();
    let run = |pass: &mut DiffusionPass, medium: &Medium, opts: &SolveOptions| {
        let sources = single(&ctx, &rbfs, medium, 2);
        pass.run(&ctx, &ops, medium, &sources, opts).unwrap();
        pass.stats(&ctx).unwrap().unwrap()
    };
    let cold = run(&mut pass, &medium, &solve);
    assert!(cold.converged && cold.iterations > 5, "{cold:?}");
    // The same system again: it starts at its solution.
    let warm = run(&mut pass, &medium, &solve);
    assert!(
        warm.converged && warm.iterations * 4 < cold.iterations,
        "warm {warm:?}, cold {cold:?}"
    );
    // A slightly different medium, two iterations: from the last solution the residual is
    // far smaller than from zero.
    let near = Medium::new(8.4, 0.9, 0.3).unwrap();
    let short = SolveOptions {
        max_iterations: 2,
        tolerance: 1e-12,
    };
    let warm = run(&mut pass, &near, &short);
    pass.reset();
    let cold = run(&mut pass, &near, &short);
    assert_eq!((warm.iterations, cold.iterations), (2, 2));
    assert!(
        warm.residual < 0.2 * cold.residual,
        "warm {warm:?}, cold {cold:?}"
    );
    // A cap that is not a multiple of the iterations per dispatch (16): exactly that many.
    let capped = SolveOptions {
        max_iterations: 37,
        tolerance: 1e-12,
    };
    let stats = run(&mut pass, &medium, &capped);
    assert_eq!(stats.iterations, 37, "{stats:?}");
    assert!(!stats.converged, "{stats:?}");
}
