//! Paper D's composite on the GPU (`gpu::analytic`) against the CPU's
//! (`analytic::render` with paper C's `Analytic` model), pixel by pixel, on small
//! images: the bundled analytic fog (every family, the sky, a sun, a point light) late in
//! its wind; two analytic fogs of different colours over a homogeneous medium with the
//! environment at ∞ (the fogs end at their `far`); and the same with the first fog dense
//! (σt = 40: τ → 0 near the ground, the fogs' colours alone).
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Tolerance.** Per pixel and channel
//! `|C_gpu − C_cpu| ≤ REL·|C_cpu| + FLOOR·C̄ + FOG·C_fog`, `C̄` the CPU image's mean.
//! `C_fin = τ C_in + (1 − τ) C_fog` moves with the depth `D` by
//! `τ·(C_fog − C_in)·δD`: the WGSL closed forms hold `D` to 10⁻⁴ relative
//! (crates/fogfn/tests/gpu_twin.rs) and `τD ≤ 1/e`, so the fog's part errs by at most
//! `3.7·10⁻⁵·(C_fog + C_in)`; `FOG = 10⁻⁴` and the `C_in` part inside `REL` bound it.
//! `C_in` is paper C's picture, held to `REL = 5·10⁻⁴`, `FLOOR = 10⁻⁵` by
//! crates/scene/tests/gpu_render.rs (measured there ≤ 3.3·10⁻⁵), scaled by `τ ≤ 1`; the
//! hit distance is recomputed in `f32` (10⁻⁷ relative, below both). Pixels on a
//! silhouette may take the other side in `f32`: at most `OUTLIERS` of them (the count per
//! case is printed). Measured on lavapipe: at most 7·10⁻⁶ relative, no outliers.

use haze_scene::analytic;
use haze_scene::gpu::GpuRenderer;
use haze_scene::gpu::analytic::GpuAnalytic;
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::Analytic;
use haze_scene::{Scene, file};
use std::sync::OnceLock;

mod common;
use common::{Tolerance, assert_agree, context};

const REL: f64 = 5e-4;
const FLOOR: f64 = 1e-5;
const FOG: f64 = 1e-4;
const OUTLIERS: f64 = 0.01;

fn composite() -> &'static GpuAnalytic {
    static R: OnceLock<GpuAnalytic> = OnceLock::new();
    R.get_or_init(|| GpuAnalytic::new(context()).unwrap())
}

/// The GPU picture against the CPU's (module docs).
fn compare(name: &str, scene: &Scene) {
    let lim = Limits::default();
    let model = Analytic::new(scene);
    let cpu = analytic::render(scene, &model, &lim, &|_| {});
    let tables = GpuRenderer::new(context(), &model).unwrap();
    let gpu = composite().render(context(), &tables, scene, &lim).unwrap();
    let fog_max = analytic::fog_colours(scene)
        .iter()
        .fold([0.0f64; 3], |a, (_, c)| [0, 1, 2].map(|k| a[k].max(c[k])));
    let tol = Tolerance {
        extra: fog_max.map(|f| FOG * f),
        ..Tolerance::new(REL, FLOOR, OUTLIERS)
    };
    assert_agree(name, &gpu, &cpu, tol);
}

#[test]
fn the_bundled_analytic_fog_late_in_its_wind() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../data/scenes/analytic_fog.json"
    );
    let mut s = haze_scene::load(std::path::Path::new(path))
        .unwrap()
        .at_time(7.5);
    s.camera = s.camera.with_size(40, 30).unwrap();
    // The fog must show: the composite changed the picture.
    let mut clear = s.clone();
    clear.hetero.clear();
    let lim = Limits::default();
    let model = Analytic::new(&s);
    let fogged = analytic::render(&s, &model, &lim, &|_| {});
    let bare = haze_scene::render::render(&clear, &model, &lim, &|_| {});
    assert_ne!(fogged.pixels, bare.pixels);
    compare("bundled analytic fog", &s);
}

const TWO_FOGS: &str = r#"{
    "camera": {"eye": [0, -6, 1.6], "target": [0, 0, 0.8], "fov": 55, "width": 32, "height": 24},
    "environment": [0.1, 0.12, 0.15],
    "lights": [{"type": "point", "position": [-1.2, -0.5, 1.8], "intensity": [6, 5, 4]}],
    "media": [
        {"type": "homogeneous", "sigma_t": 0.05, "albedo": 0.9},
        {"type": "analytic", "sigma_t": [0.3, 0.2, 0.1], "colour": [0.8, 0.6, 0.4], "far": 12,
         "terms": [{"type": "height", "weight": 0.8, "falloff": 1.5, "base": 0.2},
                   {"type": "blob", "weight": 3.0, "shape": "sphere", "center": [0.8, 0.0, 0.5], "radius": 0.5, "c": 0.6, "d": 2.0}]},
        {"type": "analytic", "sigma_t": 0.2, "albedo": 0.7, "far": 8,
         "terms": [{"type": "constant", "weight": 0.2},
                   {"type": "polynomial", "weight": 0.3, "axes": [[1, 0, 0], [0, 1, 0]], "half_width": 1.5, "monomials": [[1.0, 0, 0], [-0.1, 2, 0], [-0.1, 0, 2]]}]}
    ],
    "surfaces": [
        {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {"diffuse": [0.6, 0.6, 0.6]}},
        {"type": "sphere", "center": [0.2, 0.5, 0.7], "radius": 0.7,
         "material": {"diffuse": [0.7, 0.3, 0.2], "specular": [0.3, 0.3, 0.3], "shininess": 12}}
    ]
}"#;

#[test]
fn two_fogs_of_different_colours_with_the_environment_at_infinity() {
    let s = file::parse(TWO_FOGS).unwrap();
    assert!(s.environment_distance.is_infinite());
    assert_eq!(s.analytic_media().count(), 2);
    compare("two fogs", &s);
}

#[test]
fn a_dense_fog_hides_the_scene() {
    let text = TWO_FOGS.replacen(r#""sigma_t": [0.3, 0.2, 0.1]"#, r#""sigma_t": 40"#, 1);
    assert_ne!(text, TWO_FOGS);
    let s = file::parse(&text).unwrap();
    compare("dense layer", &s);
}
