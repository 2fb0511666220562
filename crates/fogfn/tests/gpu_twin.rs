//! The WGSL twin (`f32`) of the closed forms against the `f64` ones, ray by ray, to ≤ 10⁻⁴
//! relative, for every family, the wind, and the extremes of `closed_forms.rs` — rays
//! parallel to an axis or a line, along wave fronts, very long (10⁴), zero-length,
//! through and grazing blobs — seen from an eye far from the origin late in an animation.
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Tolerance.** The records carry the eye-dependent parts computed in `f64`; the
//! shader's own rounding is that of `f32` (ε ≈ 6·10⁻⁸) times the conditioning of each
//! form: the phase `δL/2` of a wave (absolute error ~ε·|δL|, relative to the integral
//! ~ε·|δL|·(amplitude/mean) — 10⁻⁴ at `|δL|` ≈ 10³·mean/amplitude), `Φ(b) − Φ(a)` of a
//! periodic polynomial (~ε times the cells crossed, relative to their sum), `1 − e^{−x}` in a
//! height layer (~ε/x ≤ 6·10⁻⁶ for `|x| ≥ 10⁻²`) and the `atan2`/`log` of the blobs. Errors
//! are taken relative to `∫|K|` (the integral itself for a non-negative fog). The worst per
//! case is printed.

use haze_fogfn::gpu::DepthKernel;
use haze_fogfn::vec3::{Vec3, axpy, normalize};
use haze_fogfn::{Fog, spec};
use haze_gpu::GpuContext;
use serde_json::json;
use std::sync::OnceLock;

const REL: f64 = 1e-4;

fn context() -> &'static GpuContext {
    static C: OnceLock<GpuContext> = OnceLock::new();
    C.get_or_init(|| match GpuContext::new() {
        Ok(ctx) => {
            println!("GPU adapter: {} ({})", ctx.adapter_name(), ctx.backend());
            ctx
        }
        Err(e) => panic!("{e}"),
    })
}

fn kernel() -> &'static DepthKernel {
    static K: OnceLock<DepthKernel> = OnceLock::new();
    K.get_or_init(|| DepthKernel::new(context()).unwrap())
}

/// `∫|K|` along a ray by the midpoint rule (the scale of the error; 10⁻³ of it is plenty).
fn abs_integral(fog: &Fog, o: Vec3, w: Vec3, len: f64, t: f64) -> f64 {
    let n = 20_000;
    let h = len / n as f64;
    (0..n)
        .map(|i| fog.density(axpy(o, (i as f64 + 0.5) * h, w), t).abs() * h)
        .sum()
}

fn check(name: &str, fog: &Fog, eye: Vec3, t: f64, rays: &[(Vec3, f64)]) {
    let rays: Vec<(Vec3, f64)> = rays
        .iter()
        .map(|&(d, l)| (normalize(d).unwrap(), l))
        .collect();
    let got = kernel().run(context(), fog, eye, t, &rays).unwrap();
    let mut worst: f64 = 0.0;
    for (&(w, len), &g) in rays.iter().zip(&got) {
        let want = fog.optical_depth(eye, w, len, t);
        if want > f64::from(f32::MAX) {
            // Beyond f32 (a long ray down into a height layer): τ = 0 either way.
            assert!(g.is_infinite(), "{name}: {w:?} {len}: GPU {g}, CPU {want}");
            continue;
        }
        let scale = abs_integral(fog, eye, w, len, t).max(want.abs());
        if scale == 0.0 {
            assert_eq!(g, 0.0, "{name}: {w:?} {len}");
            continue;
        }
        let rel = (f64::from(g) - want).abs() / scale;
        assert!(
            rel <= REL,
            "{name}: ray {w:?} len {len}: GPU {g}, CPU {want} (rel {rel:.2e})"
        );
        worst = worst.max(rel);
    }
    println!("{name}: worst relative error {worst:.2e}");
}

fn fog(wind: Vec3, terms: serde_json::Value) -> Fog {
    spec::fog(wind, terms.as_array().unwrap()).unwrap()
}

/// A spread of directions plus the given ones.
fn dirs(lens: &[f64], special: &[(Vec3, f64)]) -> Vec<(Vec3, f64)> {
    let mut out = Vec::new();
    for i in 0..24 {
        let a = i as f64 * 0.7;
        let z = (i as f64 / 23.0) * 1.8 - 0.9;
        let r = (1.0 - z * z).sqrt();
        for &l in lens {
            out.push(([r * a.cos(), r * a.sin(), z], l));
        }
    }
    out.push(([1.0, 0.0, 0.0], 0.0));
    out.extend_from_slice(special);
    out
}

const WIND: Vec3 = [0.8, -0.3, 0.1];
/// Far from the origin, late: the records must carry this in f64.
const EYE: Vec3 = [1250.3, -870.6, 3.2];
const T: f64 = 1234.5;

#[test]
fn cosines_on_the_gpu() {
    let pi = std::f64::consts::PI;
    let f = fog(
        WIND,
        json!([
            {"type": "constant", "weight": 1.0},
            {"type": "cosine", "weight": 0.5, "k": 5.0 * pi, "direction": [0, 1, 0], "omega": 0.3},
            {"type": "cosine", "weight": -0.2, "k": 7.0 * pi, "direction": [0.1, 1, 0]},
            {"type": "cosine_product", "weight": 0.1, "k": [pi, 0.5 * pi], "directions": [[1, 0, 0], [0, 0, 1]], "wind": false}
        ]),
    );
    check(
        "cosines",
        &f,
        EYE,
        T,
        &dirs(
            &[0.5, 7.0, 120.0],
            &[
                ([1.0, 0.0, 0.0], 50.0),
                ([0.0, 1.0, 0.0], 1e4),
                ([0.3, 0.2, 0.9], 1e4),
            ],
        ),
    );
}

#[test]
fn polynomials_on_the_gpu() {
    for (name, term) in [
        (
            "polynomial 1D periodic",
            json!({"type": "polynomial", "axes": [[1, 0, 0]], "center": [0.3, 0, 0], "half_width": 1.0, "coefficients": [0.8, -1.0, 0.0, 0.0, 1.0]}),
        ),
        (
            "polynomial 1D zero",
            json!({"type": "polynomial", "axes": [[1, 0, 0]], "center": [1250, -870, 3], "half_width": 2.0, "outside": "zero", "coefficients": [0.8, -0.3, 0.1]}),
        ),
        (
            "polynomial 2D periodic",
            json!({"type": "polynomial", "weight": 0.7, "axes": [[1, 0, 0], [0, 0, 1]], "half_width": 0.8, "monomials": [[1.0, 0, 0], [0.5, 1, 1], [-0.3, 2, 0], [0.2, 0, 3]]}),
        ),
        (
            "polynomial 3D periodic",
            json!({"type": "polynomial", "weight": 0.4, "axes": [[1, 0, 0], [0, 1, 0], [0.3, 0.3, 1]], "half_width": 1.5, "monomials": [[1.5, 0, 0, 0], [0.1, 1, 1, 1], [-0.2, 0, 2, 0], [0.05, 2, 0, 3]]}),
        ),
    ] {
        let f = fog(WIND, json!([term]));
        // Along an axis for 10⁴ with the 1D closed form; the several-axis walk for 5000
        // (≈ 3100 cells of 1.6, below its 4096; lavapipe's budget of 65535 loop
        // iterations per invocation allows as many since the walk loops only over cells
        // and monomials).
        let long = if name.contains("1D") { 1e4 } else { 5000.0 };
        check(
            name,
            &f,
            EYE,
            T,
            &dirs(
                &[0.3, 6.0, 200.0],
                &[
                    ([0.0, 1.0, 0.0], 50.0),
                    ([1e-6, 1.0, 0.0], 50.0),
                    ([1.0, 0.0, 0.0], long),
                ],
            ),
        );
    }
}

#[test]
fn blobs_and_height_on_the_gpu() {
    let near = |d: Vec3| axpy(EYE, 1.0, d);
    let f = fog(
        [0.0; 3],
        json!([
            {"type": "blob", "weight": 2.0, "shape": "point", "center": near([3.0, 0.0, 0.0]), "c": 0.5, "d": 4.0},
            {"type": "blob", "weight": 1.0, "shape": "line", "center": near([0.0, 2.0, 0.0]), "direction": [0, 0, 1], "c": 0.3, "d": 2.0},
            {"type": "blob", "weight": 1.5, "shape": "sphere", "center": near([0.0, -4.0, 0.0]), "radius": 0.8, "c": 0.4, "d": 3.0},
            // d = 0: the constant 1/c (no division by d on the GPU).
            {"type": "blob", "weight": 0.5, "shape": "line", "center": near([1.0, 1.0, 0.0]), "direction": [0, 1, 0], "c": 2.0, "d": 0.0}
        ]),
    );
    check(
        "blobs",
        &f,
        EYE,
        0.0,
        &dirs(
            &[1.0, 10.0, 1e3],
            &[
                // Through the point blob, parallel to the line, grazing the sphere.
                ([1.0, 0.0, 0.0], 10.0),
                ([0.0, 0.0, 1.0], 1e4),
                ([0.2, -4.0, 0.0], 10.0),
                ([0.0, -4.0, 0.8], 10.0),
            ],
        ),
    );
    let h = fog(
        WIND,
        json!([{"type": "height", "weight": 0.6, "falloff": 1.5, "base": 2.0, "wind": false}]),
    );
    check(
        "height",
        &h,
        EYE,
        T,
        &dirs(
            &[0.5, 8.0, 300.0],
            &[
                ([1.0, 0.0, 0.0], 1e4),
                ([0.0, 0.0, -1.0], 60.0),
                ([0.0, 0.0, 1.0], 1e4),
            ],
        ),
    );
}
