//! Single scattering at the RBF centers on the GPU against its CPU twin
//! `lighting::single::single_scattering`: every SH order, both evaluation points (center,
//! footprint), every `exp*` method, thin and thick smoke, smoke far from the origin, more
//! RBFs than a workgroup has invocations, and the extremes (no RBFs, σt = 0, albedo 0,
//! σt = 1e6, RBFs without support).
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Tolerance.** The GPU computes in `f32` (ε = 6e-8) what the CPU computes in `f64`,
//! with the same tables (rounded to `f32`) and the same operations per coefficient except
//! the order of the sum over RBFs (64 partial sums, then reduced). `exp*` turns an
//! absolute error `δf` of the optical depth `f = −σt Σ w r T` into a relative error `δf`
//! of `τ̃` (the exponential is its own derivative), so the error grows with the depth
//! `‖f‖`: `δf ≈ c·ε·‖f‖`, where `c` gathers the rounding of the distances (positions
//! relative to the first RBF, `|c_h − p|/r_h`) and of the table angle `β` (`asin`/`acos`
//! in `f32`, steep near `d = r`). The triple products of `exp*` (≈ 12 Taylor terms of up to
//! 36 rounded products each, and `k` squarings that double a relative error but start
//! from `f/2^k`) add `O(400ε)` relative, the light's triple product and the phase factor
//! `O(40ε)`. Measured on these scenes: `‖ΔJ‖/‖J‖ ≤ 3e-5·max(1, ‖f‖)` (c ≈ 500), so the
//! tests take `tol = 4 × 3e-5·max(1, ‖f‖_max)` — a margin of four — for `J̃ss` per center
//! and channel as vectors, `‖ΔJ‖₂ ≤ tol·‖J‖₂ + 1e-12`, and for the escape probability
//! (`τ̃_00/√4π`). The measured errors are printed (`--nocapture`).

use haze_gpu::GpuContext;
use haze_view::gpu::single_scattering::{SingleScatteringPass, single_scattering};
use haze_view::lighting::single::{self, RgbSh, ShKit, SingleScattering, SourcePoints};
use haze_view::sh::{self, ExpMethod};
use haze_view::{Environment, Medium, Sky};
use haze_volume::{Bbox, Rbf};

mod common;
use common::context;

/// The shared cluster, shifted by `offset` on every axis.
fn cluster(offset: f64) -> Vec<Rbf> {
    common::cluster(&Bbox::new([offset; 3], [offset + 1.0; 3]))
}

/// `n` RBFs scattered by a fixed linear congruential sequence in the unit cube.
fn scattered(n: usize) -> Vec<Rbf> {
    let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let c = [next(), next(), next()];
            Rbf::new(c, 0.04 + 0.1 * next(), 0.2 + next())
        })
        .collect()
}

fn light(order: usize) -> RgbSh {
    sh::project_env(&Environment::sky(Sky::default()), order)
}

/// Largest `‖f‖` (optical depth times σt, before `exp*`) over the evaluation points.
fn max_depth(kit: &ShKit, rbfs: &[Rbf], sigma_t: f64, points: SourcePoints) -> f64 {
    rbfs.iter()
        .flat_map(|b| points.points(b))
        .map(|p| {
            let f = single::optical_depth_sh(kit, rbfs, p);
            sigma_t * f.iter().map(|v| v * v).sum::<f64>().sqrt()
        })
        .fold(0.0, f64::max)
}

fn norm(v: impl Iterator<Item = f64>) -> f64 {
    v.map(|x| x * x).sum::<f64>().sqrt()
}

/// Compares GPU and CPU results; returns the largest relative error seen.
fn compare(gpu: &SingleScattering, cpu: &SingleScattering, tol: f64, what: &str) -> f64 {
    assert_eq!(gpu.source.len(), cpu.source.len(), "{what}");
    assert_eq!(gpu.escape.len(), cpu.escape.len(), "{what}");
    let mut worst: f64 = 0.0;
    for (l, (g, c)) in gpu.source.iter().zip(&cpu.source).enumerate() {
        for ch in 0..3 {
            assert_eq!(g[ch].len(), c[ch].len(), "{what}");
            let d = norm(g[ch].iter().zip(&c[ch]).map(|(a, b)| a - b));
            let m = norm(c[ch].iter().copied());
            assert!(
                d <= tol * m + 1e-12,
                "{what}: RBF {l} channel {ch}: |ΔJ| {d:.3e} vs |J| {m:.3e} (tol {tol:.1e})\ngpu {:?}\ncpu {:?}",
                g[ch],
                c[ch]
            );
            if m > 0.0 {
                worst = worst.max(d / m);
            }
        }
        let (eg, ec) = (gpu.escape[l], cpu.escape[l]);
        assert!(
            (eg - ec).abs() <= tol * ec.max(1e-300) + 1e-12 && (0.0..=1.0).contains(&eg),
            "{what}: RBF {l} escape {eg} vs {ec}"
        );
    }
    worst
}

/// Runs both and compares with the tolerance of the module docs.
#[allow(clippy::too_many_arguments)]
fn check(
    ctx: &GpuContext,
    kit: &ShKit,
    rbfs: &[Rbf],
    medium: &Medium,
    method: ExpMethod,
    points: SourcePoints,
    what: &str,
) -> f64 {
    let l = light(kit.order);
    let cpu = single::single_scattering(kit, rbfs, medium, &l, method, points);
    let gpu = single_scattering(ctx, kit, rbfs, medium, &l, method, points)
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    let depth = max_depth(kit, rbfs, medium.sigma_t, points);
    let tol = 4.0 * 3e-5 * depth.max(1.0);
    let worst = compare(&gpu, &cpu, tol, what);
    println!("{what}: max ‖f‖ {depth:.2}, worst relative error {worst:.2e} (tol {tol:.1e})");
    worst
}

#[test]
fn every_order_and_both_source_points_match_the_cpu() {
    let ctx = context();
    let rbfs = cluster(0.0);
    for order in 1..=6 {
        let kit = ShKit::new(order);
        for points in [SourcePoints::Center, SourcePoints::Footprint] {
            for (sigma_t, g) in [(3.0, 0.0), (30.0, 0.6)] {
                let medium = Medium::new(sigma_t, 0.9, g).unwrap();
                check(
                    &ctx,
                    &kit,
                    &rbfs,
                    &medium,
                    ExpMethod::ScaleSquareAuto,
                    points,
                    &format!("order {order}, {points:?}, σt {sigma_t}, g {g}"),
                );
            }
        }
    }
}

#[test]
fn every_exp_method_matches_the_cpu() {
    let ctx = context();
    let rbfs = cluster(0.0);
    let medium = Medium::new(20.0, 0.8, -0.3).unwrap();
    for order in [2, 4] {
        let kit = ShKit::new(order);
        for method in [
            ExpMethod::OptimalLinear,
            ExpMethod::ScaleSquare { halvings: 0 },
            ExpMethod::ScaleSquare { halvings: 3 },
            ExpMethod::ScaleSquareAuto,
        ] {
            check(
                &ctx,
                &kit,
                &rbfs,
                &medium,
                method,
                SourcePoints::Footprint,
                &format!("order {order}, {method:?}"),
            );
        }
    }
}

#[test]
fn thick_smoke_far_from_the_origin_and_many_rbfs_match_the_cpu() {
    let ctx = context();
    let kit = ShKit::new(4);
    // Optical depths in the hundreds: k ≈ 8 squarings, transmittance down to e⁻¹⁰⁰.
    let thick = Medium::new(400.0, 0.95, 0.5).unwrap();
    check(
        &ctx,
        &kit,
        &cluster(0.0),
        &thick,
        ExpMethod::ScaleSquareAuto,
        SourcePoints::Footprint,
        "σt 400",
    );
    // Smoke 5000 units from the origin: the same answer as at the origin.
    let medium = Medium::new(10.0, 0.9, 0.2).unwrap();
    let far: Vec<Rbf> = cluster(0.0)
        .iter()
        .map(|b| {
            Rbf::new(
                b.center.map(|v| 5000.0 + 10.0 * v),
                10.0 * b.radius,
                b.weight,
            )
        })
        .collect();
    let scaled = Medium::new(1.0, 0.9, 0.2).unwrap();
    check(
        &ctx,
        &kit,
        &far,
        &scaled,
        ExpMethod::ScaleSquareAuto,
        SourcePoints::Footprint,
        "5000 units out",
    );
    // 150 RBFs: every invocation of a workgroup sums two or three of them.
    check(
        &ctx,
        &kit,
        &scattered(150),
        &medium,
        ExpMethod::ScaleSquareAuto,
        SourcePoints::Footprint,
        "150 RBFs",
    );
}

#[test]
fn extremes_match_the_cpu_and_stay_finite() {
    let ctx = context();
    let kit = ShKit::new(3);
    let l = light(3);
    let run = |rbfs: &[Rbf], medium: &Medium| {
        single_scattering(
            &ctx,
            &kit,
            rbfs,
            medium,
            &l,
            ExpMethod::ScaleSquareAuto,
            SourcePoints::Footprint,
        )
        .unwrap()
    };
    // No RBFs: nothing, and no dispatch.
    let none = run(&[], &Medium::new(1.0, 0.9, 0.0).unwrap());
    assert!(none.source.is_empty() && none.escape.is_empty());

    // σt = 0: τ̃ = 1, escape 1, J = (Ω/4π)(L ⋆ p).
    let rbfs = cluster(0.0);
    let clear = Medium::new(0.0, 0.9, 0.4).unwrap();
    let cpu = single::single_scattering(
        &kit,
        &rbfs,
        &clear,
        &l,
        ExpMethod::ScaleSquareAuto,
        SourcePoints::Footprint,
    );
    let gpu = run(&rbfs, &clear);
    compare(&gpu, &cpu, 1e-5, "σt 0");
    assert!(gpu.escape.iter().all(|&p| (p - 1.0).abs() < 1e-6));

    // Albedo 0: no source at all, the escape unchanged.
    let black = Medium::new(5.0, 0.0, 0.0).unwrap();
    let gpu = run(&rbfs, &black);
    assert!(gpu.source.iter().flatten().flatten().all(|&v| v == 0.0));
    assert!(gpu.escape.iter().all(|&p| p > 0.0 && p < 1.0));

    // σt = 1e6: opaque, finite, nothing escapes.
    let opaque = Medium::new(1e6, 0.9, 0.0).unwrap();
    let gpu = run(&rbfs, &opaque);
    assert!(gpu.source.iter().flatten().flatten().all(|v| v.is_finite()));
    assert!(
        gpu.escape.iter().all(|&p| (0.0..1e-6).contains(&p)),
        "{:?}",
        gpu.escape
    );

    // RBFs without support (zero radius, zero weight) cast no shadow: the same result
    // as without them, for the others.
    let mut with_dead = rbfs.clone();
    with_dead.push(Rbf::new([0.5; 3], 0.0, 5.0));
    with_dead.push(Rbf::new([0.45; 3], 0.2, 0.0));
    let medium = Medium::new(8.0, 0.9, 0.0).unwrap();
    let a = run(&with_dead, &medium);
    let b = run(&rbfs, &medium);
    let trimmed = SingleScattering {
        source: a.source[..rbfs.len()].to_vec(),
        escape: a.escape[..rbfs.len()].to_vec(),
    };
    compare(&trimmed, &b, 1e-6, "dead RBFs");
}

#[test]
fn a_pass_is_reused_across_frames_and_refuses_other_orders() {
    let ctx = context();
    let kit = ShKit::new(2);
    let pass = SingleScatteringPass::new(&ctx, &kit).unwrap();
    let medium = Medium::new(6.0, 0.9, 0.1).unwrap();
    let l = light(2);
    for n in [6, 40, 3] {
        let rbfs = scattered(n);
        let gpu = pass
            .run(
                &ctx,
                &kit,
                &rbfs,
                &medium,
                &l,
                ExpMethod::ScaleSquareAuto,
                SourcePoints::Center,
            )
            .unwrap()
            .read(&ctx)
            .unwrap();
        let cpu = single::single_scattering(
            &kit,
            &rbfs,
            &medium,
            &l,
            ExpMethod::ScaleSquareAuto,
            SourcePoints::Center,
        );
        let depth = max_depth(&kit, &rbfs, medium.sigma_t, SourcePoints::Center);
        compare(
            &gpu,
            &cpu,
            4.0 * 3e-5 * depth.max(1.0),
            &format!("{n} RBFs"),
        );
    }
    let other = ShKit::new(3);
    let e = pass
        .run(
            &ctx,
            &other,
            &scattered(3),
            &medium,
            &light(3),
            ExpMethod::ScaleSquareAuto,
            SourcePoints::Center,
        )
        .unwrap_err();
    assert!(e.to_string().contains("order 3"), "{e}");
    let e = pass
        .run(
            &ctx,
            &kit,
            &scattered(3),
            &medium,
            &light(3),
            ExpMethod::ScaleSquareAuto,
            SourcePoints::Center,
        )
        .unwrap_err();
    assert!(e.to_string().contains("SH coefficients"), "{e}");
}
