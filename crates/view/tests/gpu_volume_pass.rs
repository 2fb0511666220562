//! The GPU volume pass against its CPU twin `crm::volume_pass`, on small RBF scenes at SH
//! orders 1, 2, 4 and 6, with and without a residual (a real hash volume built from
//! quantized data, the CPU given the slot's dense residual); and the chained GPU volume
//! and view passes against `crm_render`.
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Tolerance of the grids.** The GPU computes in `f32` what the CPU computes in `f64`.
//! An RBF's `q = |u − c|/r` comes from coordinates rounded to `f32` relative to the box
//! (absolute error ≈ ε·L, ε = 2⁻²⁴, L the box side), so `δq ≲ ε(2L/r + 6)` and
//! `δ(q²) ≤ 2q·δq ≤ 6·δq` inside the support: ≈ 2e-5 for these scenes (r ≥ L/15); `exp`
//! adds its `3 + 2|x|` ulp (≤ 21 ulp ≈ 1.3e-6 at the cut-off). Each term `w B` is
//! therefore within ≈ 2.5e-5 relative, and so is `D̃`, a sum of positive terms:
//! `|ΔD| ≤ 1e-4·D̃` (then `D = max(D̃ + R, 0)` with `R` exact — the hash's dequantization
//! is the CPU's to the bit — and the clamp cannot add error). `J̃` is a weighted mean of
//! `y(d)·J̃(c_ℓ)` whose terms may cancel, so its error is bounded by the same relative
//! figure (plus `n²` roundings of the dot products, ≈ 36ε) times the mean of the
//! magnitudes, `S = Σ_ℓ w_ℓ B_ℓ Σ_k |y_k J̃_k(c_ℓ)| / D̃`: `|ΔJ̃| ≤ 1e-4·S`. Both leave a
//! margin of four over the estimate (measured: below 1e-6 relative, see the printed
//! figures). Voxel centers whose `q²` lies within 1e-3 of the cut-off 9 for some RBF are
//! decided by rounding (the RBF's `w·e⁻⁹` is in or out, and with it the residual where it
//! is the only one): they are counted, required to be rare, and not compared.

use haze_gpu::GpuContext;
use haze_gpu::GpuError;
use haze_hash::tile::ResidualGroup;
use haze_hash::{BuildOptions, QuantOptions, quantize};
use haze_view::gpu::GridBuffer;
use haze_view::gpu::view_pass::ViewPass;
use haze_view::gpu::volume_pass::{Residual, VolumePass, volume_pass};
use haze_view::lighting::single::RgbSh;
use haze_view::render::crm::{self, MIN_DENSITY, OPAQUE, VolumeGrids};
use haze_view::render::env_pass::EnvSource;
use haze_view::render::{CrmOptions, crm_render, crm_sources, slice_thickness};
use haze_view::sh;
use haze_view::stream::ResidualSlot;
use haze_view::{Camera, Environment, Medium, Sky};
use haze_volume::{Bbox, Rbf};
use std::sync::Arc;
use std::time::Instant;

mod common;
use common::{cluster, context, unit_box};

/// Paper A's chain (the environment's single scattering at the centers, through the
/// volume pass): the environment pass has its own twin test (`tests/gpu_env_pass.rs`)
/// and the whole GPU frame `tests/gpu_renderer.rs`.
fn opts(order: usize) -> CrmOptions {
    CrmOptions {
        order,
        env_source: EnvSource::Centers,
        ..CrmOptions::default()
    }
}

/// Source radiance at the centers: single + multiple scattering of `order`.
fn sources(rbfs: &[Rbf], order: usize, medium: &Medium, env: &Environment) -> Vec<RgbSh> {
    crm_sources(rbfs, medium, env, &opts(order)).0
}

fn voxel_center(bbox: &Bbox, dims: [usize; 3], i: usize) -> [f64; 3] {
    let idx = [
        i % dims[0],
        (i / dims[0]) % dims[1],
        i / (dims[0] * dims[1]),
    ];
    let s = bbox.size();
    [0, 1, 2].map(|a| bbox.min[a] + (idx[a] as f64 + 0.5) * s[a] / dims[a] as f64)
}

/// Largest errors found, relative to each voxel's tolerance scale (`D̃` for the density,
/// `S` for the radiance), and the voxels left out at the cut-off.
#[derive(Debug, Default)]
struct Errors {
    density: f64,
    radiance: f64,
    at_cutoff: usize,
}

/// Checks the GPU grids against the CPU's voxel by voxel with the tolerances of the
/// module docs; the scales `D̃`, `S` and the cut-off test are recomputed here in `f64`.
#[allow(clippy::too_many_arguments)]
fn compare_grids(
    gpu: &VolumeGrids,
    cpu: &VolumeGrids,
    rbfs: &[Rbf],
    source: &[RgbSh],
    order: usize,
    dims: [usize; 3],
    bbox: &Bbox,
    eye: [f64; 3],
) -> Errors {
    let voxels = dims.iter().product::<usize>();
    assert_eq!(gpu.density.dims(), dims);
    assert_eq!(gpu.density.bbox(), bbox);
    assert_eq!(gpu.radiance.len(), voxels);
    let mut e = Errors::default();
    let mut y = vec![0.0; order * order];
    for i in 0..voxels {
        let u = voxel_center(bbox, dims, i);
        let mut d_tilde = 0.0;
        let mut mag = [0.0f64; 3];
        let mut at_cutoff = false;
        sh::eval_into(order, [0, 1, 2].map(|a| u[a] - eye[a]), &mut y);
        for (b, j) in rbfs.iter().zip(source) {
            let q2: f64 = (0..3)
                .map(|a| ((u[a] - b.center[a]) / b.radius).powi(2))
                .sum();
            at_cutoff |= (q2 - 9.0).abs() < 1e-3;
            let v = b.eval(u);
            d_tilde += v;
            for c in 0..3 {
                mag[c] += v.abs() * j[c].iter().zip(&y).map(|(s, y)| (s * y).abs()).sum::<f64>();
            }
        }
        let (g_d, c_d) = (
            f64::from(gpu.density.data()[i]),
            f64::from(cpu.density.data()[i]),
        );
        let (g_j, c_j) = (gpu.radiance[i], cpu.radiance[i]);
        assert!(
            g_d.is_finite() && g_j.iter().all(|v| v.is_finite()),
            "voxel {i}: {g_d} {g_j:?}"
        );
        if at_cutoff || (d_tilde - MIN_DENSITY).abs() < 1e-3 * MIN_DENSITY {
            e.at_cutoff += 1;
            continue;
        }
        let err = (g_d - c_d).abs();
        assert!(
            err <= 1e-4 * d_tilde.abs() + 2e-7 * c_d.abs(),
            "voxel {i} density: GPU {g_d}, CPU {c_d} (D̃ {d_tilde})"
        );
        if d_tilde.abs() > 0.0 {
            e.density = e.density.max(err / d_tilde.abs());
        }
        for c in 0..3 {
            let (g, q) = (f64::from(g_j[c]), f64::from(c_j[c]));
            let scale = if d_tilde >= MIN_DENSITY {
                mag[c] / d_tilde
            } else {
                0.0
            };
            let err = (g - q).abs();
            assert!(
                err <= 1e-4 * scale + 2e-7 * q.abs(),
                "voxel {i} channel {c}: GPU {g}, CPU {q} (scale {scale})"
            );
            if scale > 0.0 {
                e.radiance = e.radiance.max(err / scale);
            }
        }
    }
    assert!(
        e.at_cutoff * 1000 <= voxels,
        "{} of {voxels} voxels at an RBF's cut-off",
        e.at_cutoff
    );
    e
}

/// Both volume passes on one scene; returns the GPU grids after the comparison.
#[allow(clippy::too_many_arguments)]
fn check(
    ctx: &GpuContext,
    rbfs: &[Rbf],
    source: &[RgbSh],
    order: usize,
    dims: [usize; 3],
    bbox: &Bbox,
    residual: Option<&ResidualSlot>,
    eye: [f64; 3],
) -> VolumeGrids {
    let dense = residual.map(ResidualSlot::dense);
    let t = Instant::now();
    let cpu = crm::volume_pass(rbfs, source, order, dims, bbox, dense.as_deref(), eye);
    let cpu_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let gpu = volume_pass(
        ctx,
        rbfs,
        source,
        order,
        dims,
        bbox,
        residual.map(Residual::Hash),
        eye,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let gpu_s = t.elapsed().as_secs_f64();
    let e = compare_grids(&gpu, &cpu, rbfs, source, order, dims, bbox, eye);
    println!(
        "order {order}, {dims:?}{}: max density error {:.2e}·D̃, radiance {:.2e}·S, {} voxels at a cut-off; CPU {cpu_s:.3} s, GPU {gpu_s:.3} s (with pipeline creation)",
        if residual.is_some() { ", residual" } else { "" },
        e.density,
        e.radiance,
        e.at_cutoff
    );
    gpu
}

#[test]
fn orders_1_2_4_6_match_the_cpu() {
    let ctx = context();
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(4.0, 0.8, 0.3).unwrap();
    let eye = [0.5, -1.3, 0.85];
    // Not multiples of the 4×4×4 tiles.
    let dims = [21, 18, 23];
    for order in [1, 2, 4, 6] {
        let source = sources(&rbfs, order, &medium, &env);
        check(&ctx, &rbfs, &source, order, dims, &bbox, None, eye);
    }
}

#[test]
fn eye_inside_a_box_far_from_the_origin_with_uneven_voxels() {
    // World coordinates in the hundreds; the eye among the RBFs, so the directions to the
    // voxels cover the whole sphere (every octant, near both poles).
    let ctx = context();
    let bbox = Bbox::new([120.0, -40.0, 15.0], [121.5, -39.0, 17.0]);
    let dims = [24, 14, 33];
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(6.0, 0.7, -0.4).unwrap();
    let eye = [120.731, -39.517, 16.093];
    for order in [2, 6] {
        let source = sources(&rbfs, order, &medium, &env);
        check(&ctx, &rbfs, &source, order, dims, &bbox, None, eye);
    }
}

#[test]
fn sh_basis_matches_sh_eval_for_every_coefficient() {
    // One RBF covering the grid, its source the k-th basis function in red and its
    // negative in green: J̃ = (max(y_k(d), 0), max(−y_k(d), 0), 0) at every voxel, so each
    // of the 36 functions of order 6 is checked on its own, both signs, in all directions
    // around an eye at the box's center (between voxel centers).
    let ctx = context();
    let pass = VolumePass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = unit_box();
    let dims = [8, 8, 8];
    let rbfs = [Rbf::new([0.5; 3], 10.0, 1.0)];
    let eye = [0.5; 3];
    let order = 6;
    let mut worst = 0.0f64;
    for k in 0..order * order {
        let mut e = vec![0.0; order * order];
        e[k] = 1.0;
        let source = vec![[e.clone(), e.iter().map(|v| -v).collect(), vec![0.0; 36]]];
        let g = pass
            .run(&ctx, &rbfs, &source, order, dims, &bbox, None, eye)
            .and_then(|b| b.read(&ctx))
            .unwrap_or_else(|e| panic!("{e}"));
        for (i, j) in g.radiance.iter().enumerate() {
            let u = voxel_center(&bbox, dims, i);
            let y = sh::eval(order, [0, 1, 2].map(|a| u[a] - eye[a]))[k];
            let err = (f64::from(j[0]) - y.max(0.0))
                .abs()
                .max((f64::from(j[1]) - (-y).max(0.0)).abs());
            // |y_k| ≤ √(11/4π) ≈ 0.94; the recurrence's f32 roundings are a few ulp.
            assert!(err < 1e-5, "coefficient {k}, voxel {i}: {j:?} vs {y}");
            assert_eq!(j[2], 0.0);
            worst = worst.max(err);
        }
    }
    println!("SH basis, order 6: max error {worst:.2e}");
}

/// A residual group of `frames` frames of `dims` in bricks of `brick`: frame `j` is
/// `D_j − D̃`, with `D_j` the cluster's density scaled and rippled differently per frame
/// (both signs, and non-zero outside every RBF's support too), quantized at an error that
/// cycles through 1e-4, 1/255 and 0.03 of the peak and 0 (lossless), so that bricks of
/// every width (2, 4, 8, 16 bits and f32) sit in one block.
fn residual_group(
    rbfs: &[Rbf],
    dims: [usize; 3],
    bbox: &Bbox,
    frames: usize,
    brick: u32,
) -> Arc<ResidualGroup> {
    let approx = haze_volume::rbf::evaluate_on_grid(dims, bbox, rbfs);
    let quantized: Vec<_> = (0..frames)
        .map(|j| {
            let r: Vec<f32> = approx
                .iter()
                .enumerate()
                .map(|(i, a)| {
                    let u = voxel_center(bbox, dims, i);
                    let ripple = (7.0 * u[0] + 5.0 * u[1] - 3.0 * u[2] + j as f64).sin();
                    let target = a * (1.0 + 0.4 * ripple) + 0.05 * ripple;
                    (target - a) as f32
                })
                .collect();
            let peak = approx.iter().fold(0.0f64, |m, a| m.max(*a)) as f32;
            let error = [1e-4, 1.0 / 255.0, 0.03, 0.0][j % 4];
            quantize(&r, peak, QuantOptions { error, bits: 16 }).unwrap()
        })
        .collect();
    let d = dims.map(|n| n as u32);
    let group = ResidualGroup::build(d, brick, &quantized, BuildOptions::default()).unwrap();
    let widths: std::collections::BTreeSet<u32> = group
        .hash
        .payloads
        .iter()
        .zip(&group.hash.keys)
        .filter(|&(_, &k)| k != 0)
        .map(|(&p, _)| p & 7)
        .collect();
    if frames >= 4 {
        assert_eq!(widths.len(), 5, "widths {widths:?}");
    }
    // As an asset stores and a reader decodes it.
    let decoded = haze_hash::block::decode(&haze_hash::block::encode(&group).unwrap()).unwrap();
    assert_eq!(decoded, group);
    Arc::new(decoded)
}

#[test]
fn hash_residual_matches_the_cpu_given_the_dense_slot() {
    let ctx = context();
    let bbox = Bbox::new([-0.2, 0.1, 0.0], [0.8, 1.3, 0.9]);
    let dims = [14, 17, 11];
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(4.0, 0.8, 0.3).unwrap();
    let eye = [0.3, -1.1, 0.7];
    let pass = VolumePass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    // Bricks of every width (the sign extension of every packed position), and of sides 4,
    // 2 and 8 (17 and 11 voxels: bricks past the frame's edge). 20 frames: the slots tested
    // sit in tiles along every axis of the 3×3×3 layout, at every error of the cycle.
    for (brick, order, slots) in [
        (4u32, 2usize, vec![0usize, 5, 19]),
        (2, 6, vec![10, 11]),
        (8, 2, vec![13, 14]),
    ] {
        let group = residual_group(&rbfs, dims, &bbox, 20, brick);
        let source = sources(&rbfs, order, &medium, &env);
        let without = check(&ctx, &rbfs, &source, order, dims, &bbox, None, eye);
        for slot in slots {
            let slot = ResidualSlot {
                group: group.clone(),
                slot,
            };
            let dense = slot.dense();
            assert!(dense.iter().any(|r| *r < 0.0) && dense.iter().any(|r| *r > 0.0));
            let with = check(&ctx, &rbfs, &source, order, dims, &bbox, Some(&slot), eye);
            assert_ne!(with.density.data(), without.density.data());
            // The clamp D = max(D̃ + R, 0) is reached inside the smoke.
            let clamped = (0..dense.len())
                .filter(|&i| with.density.data()[i] == 0.0 && without.density.data()[i] > 0.0)
                .count();
            assert!(clamped > 0, "slot {}: no clamped voxel", slot.slot);
            // The hash looked up on the GPU gives the residual to the bit: the same grids
            // as the dense upload of the CPU's lookups.
            let from_dense = pass
                .run(
                    &ctx,
                    &rbfs,
                    &source,
                    order,
                    dims,
                    &bbox,
                    Some(Residual::Dense(&dense)),
                    eye,
                )
                .and_then(|b| b.read(&ctx))
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(from_dense.density.data(), with.density.data());
            assert_eq!(from_dense.radiance, with.radiance);
        }
    }
}

/// `|gpu − cpu| ≤ 2e-4·|cpu| + (OPAQUE + 2e-4)·brightest` per pixel and channel: the
/// view pass's own `f32` error (1e-4 relative, and `OPAQUE` for an early exit a slice
/// apart, `tests/gpu_view_pass.rs`) plus the grids' (≤ 1e-4 of the scales above): a
/// pixel is a weighted sum of `J̃` values and the background with weights ≤ 1 in total,
/// and a relative change `δ` of the densities moves those weights by at most `δ` times
/// `x e⁻ˣ ≤ 1/e` of each, so by `δ·brightest` at most.
fn compare_images(gpu: &[[f32; 3]], cpu: &[[f32; 3]], brightest: f64, width: usize) -> f64 {
    assert_eq!(gpu.len(), cpu.len());
    let slack = (OPAQUE + 2e-4) * brightest;
    let mut max_abs = 0.0f64;
    for (i, (p, q)) in gpu.iter().zip(cpu).enumerate() {
        for c in 0..3 {
            let (p, q) = (f64::from(p[c]), f64::from(q[c]));
            let err = (p - q).abs();
            assert!(
                err <= 2e-4 * q.abs() + slack,
                "pixel ({}, {}) channel {c}: GPU {p}, CPU {q}",
                i % width,
                i / width
            );
            max_abs = max_abs.max(err);
        }
    }
    max_abs / brightest
}

#[test]
fn chained_gpu_passes_match_crm_render() {
    // Sources at the centers on the CPU, then the GPU volume pass straight into the GPU
    // view pass (no readback of the grids), against `crm_render` on the CPU: without and
    // with a residual.
    let ctx = context();
    let volume = VolumePass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let view = ViewPass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = unit_box();
    let dims = [20, 24, 18];
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(5.0, 0.8, 0.3).unwrap();
    let cam = Camera::new(
        [0.5, -1.3, 0.85],
        [0.5, 0.5, 0.52],
        [0.0, 0.0, 1.0],
        40.0,
        44,
        30,
    )
    .unwrap();
    let group = residual_group(&rbfs, dims, &bbox, 5, 8);
    let slot = ResidualSlot { group, slot: 3 };
    let dense = slot.dense();
    for residual in [false, true] {
        let o = CrmOptions {
            residual,
            ..opts(4)
        };
        let (cpu, _) = crm_render(&rbfs, Some(&dense), dims, &bbox, &medium, &env, &cam, &o);
        let (source, _) = crm_sources(&rbfs, &medium, &env, &o);
        let t = Instant::now();
        let grid = volume
            .run(
                &ctx,
                &rbfs,
                &source,
                o.order,
                dims,
                &bbox,
                residual.then_some(Residual::Hash(&slot)),
                cam.eye,
            )
            .unwrap_or_else(|e| panic!("{e}"));
        let du = slice_thickness(dims, &bbox, &o);
        let gpu = view
            .run_on(&ctx, &grid, &medium, &env, &cam, du, None)
            .unwrap_or_else(|e| panic!("{e}"));
        let gpu_s = t.elapsed().as_secs_f64();
        let mut brightest: f64 = 0.0;
        for y in 0..cam.height {
            for x in 0..cam.width {
                let b = env.radiance(cam.pixel_ray(x, y));
                brightest = brightest.max(b.into_iter().fold(0.0, f64::max));
            }
        }
        let grids = grid.read(&ctx).unwrap_or_else(|e| panic!("{e}"));
        for j in &grids.radiance {
            brightest = brightest.max(j.iter().fold(0.0f32, |a, b| a.max(*b)).into());
        }
        let rel = compare_images(&gpu, &cpu.pixels, brightest, cam.width);
        println!(
            "chained passes{}: max error {rel:.2e} of the brightest radiance; GPU {gpu_s:.3} s",
            if residual { ", residual" } else { "" }
        );
    }
}

#[test]
fn a_compiled_pass_runs_many_frames_and_refuses_bad_input() {
    let ctx = context();
    let pass = VolumePass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(4.0, 0.8, 0.3).unwrap();
    let source = sources(&rbfs, 2, &medium, &env);
    let dims = [9, 10, 11];
    let eye = [0.5, -1.0, 0.5];
    let run = |rbfs: &[Rbf], source: &[RgbSh], order, dims, residual| {
        pass.run(&ctx, rbfs, source, order, dims, &bbox, residual, eye)
            .and_then(|b| b.read(&ctx))
    };
    // Deterministic: the RBFs of a tile are visited in index order.
    let a = run(&rbfs, &source, 2, dims, None).unwrap();
    let b = run(&rbfs, &source, 2, dims, None).unwrap();
    assert_eq!(a.density.data(), b.density.data());
    assert_eq!(a.radiance, b.radiance);

    // No RBFs: an empty medium, whatever the residual says (D̃ = 0 < MIN_DENSITY).
    let ones = vec![1.0f32; 990];
    let empty = run(&[], &[], 2, dims, Some(Residual::Dense(&ones))).unwrap();
    assert!(empty.density.data().iter().all(|d| *d == 0.0));
    assert!(empty.radiance.iter().all(|j| *j == [0.0; 3]));
    // An RBF without support is skipped, as on the CPU.
    let mut odd = rbfs.clone();
    odd[2].radius = 0.0;
    odd[4].radius = f64::NAN;
    let g = run(&odd, &source, 2, dims, None).unwrap();
    let c = crm::volume_pass(&odd, &source, 2, dims, &bbox, None, eye);
    compare_grids(&g, &c, &odd, &source, 2, dims, &bbox, eye);
    // An empty grid.
    let none = run(&rbfs, &source, 2, [0, 4, 4], None).unwrap();
    assert!(none.density.data().is_empty() && none.radiance.is_empty());

    let input = |r: Result<VolumeGrids, GpuError>| match r {
        Err(GpuError::Input(text)) => text,
        other => panic!("{other:?}"),
    };
    for order in [0, 7] {
        let e = input(run(&rbfs, &source, order, dims, None));
        assert_eq!(e, format!("SH order {order} is outside 1..=6"));
    }
    assert_eq!(
        input(run(&rbfs, &source[1..], 2, dims, None)),
        "5 source vectors for 6 RBFs"
    );
    assert_eq!(
        input(run(&rbfs, &source, 1, dims, None)),
        "the source of RBF 0 has more than 1 SH coefficients (order 1)"
    );
    assert_eq!(
        input(run(
            &rbfs,
            &source,
            2,
            dims,
            Some(Residual::Dense(&ones[1..]))
        )),
        "the residual has 989 voxels, the grid 990"
    );
    let slot = ResidualSlot {
        group: residual_group(&rbfs, [9, 10, 12], &bbox, 2, 4),
        slot: 1,
    };
    assert_eq!(
        input(run(&rbfs, &source, 2, dims, Some(Residual::Hash(&slot)))),
        "the residual's frames are [9, 10, 12] voxels, the grid [9, 10, 11]"
    );
    // A slot past the group's frames reads 0 everywhere, as `ResidualGroup::lookup`.
    let past = ResidualSlot {
        group: residual_group(&rbfs, dims, &bbox, 2, 4),
        slot: 2,
    };
    assert!(past.dense().iter().all(|r| *r == 0.0));
    let g = run(&rbfs, &source, 2, dims, Some(Residual::Hash(&past))).unwrap();
    assert_eq!(g.density.data(), a.density.data());
    assert_eq!(g.radiance, a.radiance);
    // A grid uploaded from the CPU reads back unchanged.
    let up = GridBuffer::upload(&ctx, &a).unwrap_or_else(|e| panic!("{e}"));
    let back = up.read(&ctx).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.density.data(), a.density.data());
    assert_eq!(back.radiance, a.radiance);
}
