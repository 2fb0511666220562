//! The GPU march (`gpu::march`, taken by `GpuRenderer::render` for scenes with a smoke
//! asset) against its CPU twin (`march::render`), pixel by pixel, on small images of the
//! bundled plume over a ground plane: lit by a point light and a sun (shadows of the
//! smoke on the ground and on itself), anisotropic scattering, a homogeneous fog around
//! the smoke, and the eye inside the smoke.
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe) and fail with the
//! reason when there is none.
//!
//! **Tolerance.** Per pixel and channel `|L_gpu − L_cpu| ≤ REL·|L_cpu| + FLOOR·L̄`, `L̄`
//! the CPU image's mean. Both take the same steps and the same exact optical depths;
//! the GPU sums them in `f32` (~10⁻⁷ relative per term, a few hundred terms along a ray
//! and its shadow rays: ~10⁻⁵) and its positions relative to the eye carry ~10⁻⁷ of the
//! scene's size, which moves a step's samples by as much. Measured on lavapipe: at most
//! 10⁻⁵ relative (printed per case); `REL = 2·10⁻⁴` leaves a margin of twenty. Pixels
//! where `f32` and `f64` decide differently — a shadow ray grazing an occluder, the GPU's
//! larger offset of surfaces' shadow rays — may differ by whole terms: at most
//! `OUTLIERS` of them (none did on lavapipe).

use haze_scene::Scene;
use haze_scene::gpu::GpuRenderer;
use haze_scene::march::env_smoke::EnvLight;
use haze_scene::march::march_options;
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::{Analytic, Image};
use std::path::Path;
use std::sync::OnceLock;

mod common;
use common::{Tolerance, assert_agree, context};

const REL: f64 = 2e-4;
const FLOOR: f64 = 1e-5;
const OUTLIERS: f64 = 0.01;

/// The plume (scaled to half size) over the ground, with `media`'s extra keys and
/// `extra_media` after it.
fn scene(camera: &str, asset_keys: &str, extra_media: &str) -> Scene {
    let text = format!(
        r#"{{"camera": {camera},
            "environment": [0.1, 0.12, 0.15], "environment_distance": 8,
            "lights": [
              {{"type": "point", "position": [-0.6, -0.7, 0.5], "intensity": [2.0, 2.5, 3.5]}},
              {{"type": "sun", "direction": [0.7, -0.35, 0.62], "radiance": [2.2, 2.1, 1.9], "angle": 0}}
            ],
            "media": [
              {{"type": "asset", "path": "plume.haze", "frame": 24, "sigma_t": 8, "albedo": 0.9,
                "offset": [-0.75, -0.75, 0.1], "scale": 0.5 {asset_keys}}} {extra_media}
            ],
            "surfaces": [
              {{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                "material": {{"diffuse": [0.6, 0.58, 0.55], "specular": [0.2, 0.2, 0.2], "shininess": 12}}}}
            ]}}"#
    );
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes");
    haze_scene::file::parse_in(&text, &base).unwrap()
}

const OUTSIDE: &str =
    r#"{"eye": [0.3, -4.0, 1.5], "target": [0, 0, 0.8], "fov": 40, "width": 32, "height": 24}"#;

/// One renderer for every case (their surfaces share the Phong exponent 12).
fn renderer(s: &Scene) -> &'static GpuRenderer {
    static R: OnceLock<GpuRenderer> = OnceLock::new();
    R.get_or_init(|| GpuRenderer::new(context(), &Analytic::new(s)).unwrap())
}

fn compare(name: &str, s: &Scene) {
    let ctx = context();
    let g: Image = renderer(s).render(ctx, s, &Limits::default()).unwrap();
    let c = haze_scene::march::render(s, &Limits::default(), &march_options(s, false), &|_| {});
    assert_agree(name, &g, &c, Tolerance::new(REL, FLOOR, OUTLIERS));
}

#[test]
fn the_plume_over_the_ground_as_on_the_cpu() {
    compare("plume", &scene(OUTSIDE, "", ""));
}

#[test]
fn anisotropic_smoke_in_fog_and_the_eye_inside_it() {
    compare(
        "forward scattering in fog",
        &scene(
            OUTSIDE,
            r#", "g": 0.6"#,
            r#", {"type": "homogeneous", "sigma_t": 0.15, "albedo": 0.8}"#,
        ),
    );
    compare(
        "eye in the smoke",
        &scene(
            r#"{"eye": [0.0, -0.2, 0.9], "target": [0.3, 1.0, 0.7], "fov": 60, "width": 16, "height": 12}"#,
            "",
            "",
        ),
    );
}

#[test]
fn the_sky_lights_the_smoke_as_on_the_cpu() {
    let mut s = scene(OUTSIDE, r#", "g": 0.6"#, "");
    s.environment = haze_scene::Environment::Sky;
    // The case tests the environment's term: it adds more than 1 % (fifty times the
    // tolerance) to three times as many pixels as the outliers allowed (33 of 768).
    let opt = march_options(&s, false);
    assert!(matches!(opt.env, EnvLight::Grid(_)), "{:?}", opt.env);
    let mut none = opt.clone();
    none.env = EnvLight::None;
    let with = haze_scene::march::render(&s, &Limits::default(), &opt, &|_| {});
    let without = haze_scene::march::render(&s, &Limits::default(), &none, &|_| {});
    let lit = with
        .pixels
        .iter()
        .zip(&without.pixels)
        .filter(|(a, b)| a[1] > 1.01 * b[1])
        .count();
    println!("sky: {lit} pixels brightened by the environment's term");
    assert!(
        lit as f64 > 3.0 * OUTLIERS * with.pixels.len() as f64,
        "{lit}"
    );
    compare("sky", &s);
}
