//! The GPU march through analytic fogs (`gpu::march` with paper D's closed forms, the lit
//! picture of `render --scene --gpu --march`) against its CPU twin (`march::render`),
//! pixel by pixel, on small images: the bundled analytic fog (every family, the sky, a
//! sun and a point light, late in its wind), and the bundled plume in an analytic fog
//! (a smoke asset and analytic media marched together).
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe) and fail with the
//! reason when there is none.
//!
//! **Tolerance.** Per pixel and channel `|L_gpu − L_cpu| ≤ REL·|L_cpu| + FLOOR·L̄`, `L̄`
//! the CPU image's mean. Both take the same steps; every step's transmittance comes from
//! the fogs' closed forms, which the WGSL twin holds to 10⁻⁴ relative of the depth `D`
//! (crates/fogfn/tests/gpu_twin.rs), so `T = e^{−D}` errs by `10⁻⁴·D` relative, and a
//! camera ray with its shadow rays gathers `D ≲ 3` here: `3·10⁻⁴`. The density at each
//! step's sample (`fog_density_at`) is a handful of `f32` operations per term (10⁻⁶), the
//! sums over a few hundred steps add ~10⁻⁵. `REL = 10⁻³` leaves a margin of three over
//! that bound; measured on lavapipe (printed per case) far below it. Pixels where `f32`
//! and `f64` decide differently (a silhouette, a shadow ray grazing an occluder) may
//! differ by whole terms: at most `OUTLIERS` of them.

use haze_scene::Scene;
use haze_scene::gpu::GpuRenderer;
use haze_scene::march::march_options;
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::Analytic;
use std::path::Path;

mod common;
use common::{Tolerance, assert_agree, context};

const REL: f64 = 1e-3;
const FLOOR: f64 = 1e-5;
const OUTLIERS: f64 = 0.01;

fn scenes() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes")
}

/// The GPU march of `s` against the CPU's (module docs).
fn compare(name: &str, s: &Scene) {
    let ctx = context();
    let gpu = GpuRenderer::new(ctx, &Analytic::new(s)).unwrap();
    let g = gpu.render(ctx, s, &Limits::default()).unwrap();
    let c = haze_scene::march::render(s, &Limits::default(), &march_options(s, false), &|_| {});
    assert_agree(name, &g, &c, Tolerance::new(REL, FLOOR, OUTLIERS));
}

#[test]
fn the_lit_analytic_fog_as_on_the_cpu() {
    let mut s = haze_scene::load(&scenes().join("analytic_fog.json"))
        .unwrap()
        .at_time(7.5);
    s.camera = s.camera.with_size(16, 12).unwrap();
    compare("lit analytic fog", &s);
}

#[test]
fn smoke_in_analytic_fog_as_on_the_cpu() {
    let text = r#"{"camera": {"eye": [0.3, -4.0, 1.5], "target": [0, 0, 0.8], "fov": 40,
            "width": 16, "height": 12},
        "environment": [0.1, 0.12, 0.15], "environment_distance": 8,
        "lights": [
          {"type": "point", "position": [-0.6, -0.7, 0.5], "intensity": [2.0, 2.5, 3.5]},
          {"type": "sun", "direction": [0.7, -0.35, 0.62], "radiance": [2.2, 2.1, 1.9], "angle": 0}
        ],
        "media": [
          {"type": "asset", "path": "plume.haze", "frame": 24, "sigma_t": 8, "albedo": 0.9,
           "offset": [-0.75, -0.75, 0.1], "scale": 0.5},
          {"type": "analytic", "sigma_t": [0.3, 0.35, 0.4], "albedo": 0.8, "g": 0.3, "far": 7,
           "wind": [0.4, 0.1, 0], "terms": [
             {"type": "constant", "weight": 0.25},
             {"type": "height", "weight": 0.6, "falloff": 1.5, "base": 0.0},
             {"type": "cosine", "weight": 0.2, "k": 2.0, "direction": [1, 0.2, 0]},
             {"type": "blob", "weight": 1.5, "shape": "point", "center": [0.6, 0.4, 0.5], "c": 0.5, "d": 4.0}
           ]}
        ],
        "surfaces": [
          {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
           "material": {"diffuse": [0.6, 0.58, 0.55], "specular": [0.2, 0.2, 0.2], "shininess": 12}}
        ]}"#;
    let s = haze_scene::file::parse_in(text, &scenes())
        .unwrap()
        .at_time(3.0);
    compare("smoke in analytic fog", &s);
}
