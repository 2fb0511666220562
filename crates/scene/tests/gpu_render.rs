//! The GPU scene renderer against its CPU twin (`render::render` with paper C's
//! `Analytic` model), pixel by pixel, on small images: the bundled room, a coloured
//! medium with suns and the sky, and the extremes — a nearly clear medium (σt = 10⁻⁶), a
//! clear one with the sky at ∞, an environment farther than `f32` reaches (clamped to
//! 10³⁰ for the shader), a dense one (σt = 3), the eye inside a sphere (the medium fills
//! space: the eye is always in it), a light at the eye, a light in the middle of the view
//! (γ → 0), a plane seen at grazing angles, lights 10⁻³ above and exactly on a surface;
//! and glTF meshes (smooth and faceted, the eye close to one) through the hierarchy.
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Tolerance.** Per pixel and channel `|L_gpu − L_cpu| ≤ REL·|L_cpu| + FLOOR·L̄`, with
//! `L̄` the CPU image's mean. Both read the same `f32` tables the same way (bilinear from
//! the same nodes); the GPU computes in `f32` what the CPU computes in `f64`: ray
//! directions, distances and angles to ~10⁻⁷ relative, `atan2` within lavapipe's few ulp,
//! the table coordinates and so the interpolated `K` and `G` to ~10⁻⁶; the largest
//! relative errors come from the airlight's `1/h` peak at a light (`h = D·|u × r̂|`, a
//! cross product of nearly parallel unit vectors, ~10⁻⁷/γ relative: 3·10⁻⁴ at
//! `γ_min ≈ 4·10⁻⁴`) and from the difference of the airlight's two ends when a light lies
//! far behind a surface (absolute error ~10⁻⁷ of the near term, hence the floor).
//! Measured on lavapipe: at most 3.3·10⁻⁵ (σt → 0 and the room; 10⁻⁶–10⁻⁵ for the
//! others, printed per case); `REL = 5·10⁻⁴` leaves a margin of fifteen, `FLOOR = 10⁻⁵`
//! keeps values far below the image's from counting. Pixels where `f32` and `f64` take different discrete decisions — a ray
//! on a sphere's silhouette, a shadow ray grazing an occluder, the GPU's larger shadow
//! offset at a contact — differ by whole terms; at most `OUTLIERS` of the pixels may
//! (the count per case is printed; none did on lavapipe). The case of a light on a pixel's
//! ray holds both to `γ_min` exactly: rounding noise once put the CPU's effective light at
//! a quarter of it.

use haze_scene::gpu::GpuRenderer;
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::{Analytic, Image, render};
use haze_scene::{Scene, file};
use std::sync::OnceLock;

mod common;
use common::{Agreement, Tolerance, assert_agree, context};

const REL: f64 = 5e-4;
const FLOOR: f64 = 1e-5;
/// Largest share of pixels allowed outside the tolerance (see the module docs).
const OUTLIERS: f64 = 0.01;

/// Tables for every Phong exponent the cases use (12 and 30).
fn analytic() -> &'static Analytic {
    static A: OnceLock<Analytic> = OnceLock::new();
    A.get_or_init(|| {
        let mut s = file::parse(BASE).unwrap();
        let mut extra = s.surfaces[1].clone();
        extra.material.shininess = 30.0;
        s.surfaces.push(extra);
        Analytic::new(&s)
    })
}

fn renderer() -> &'static GpuRenderer {
    static R: OnceLock<GpuRenderer> = OnceLock::new();
    R.get_or_init(|| GpuRenderer::new(context(), analytic()).unwrap())
}

const BASE: &str = r#"{
    "camera": {"eye": [0, -6, 1.6], "target": [0, 0, 0.8], "fov": 55, "width": 32, "height": 24},
    "environment": [0.1, 0.12, 0.15],
    "lights": [
        {"type": "point", "position": [-1.2, -0.5, 1.8], "intensity": [6, 5, 4]},
        {"type": "point", "position": [1.5, 1.0, 0.6], "intensity": [1, 2, 4]}
    ],
    "media": [{"type": "homogeneous", "sigma_t": 0.25, "albedo": 0.9}],
    "surfaces": [
        {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {"diffuse": [0.6, 0.6, 0.6]}},
        {"type": "sphere", "center": [0.2, 0.5, 0.7], "radius": 0.7,
         "material": {"diffuse": [0.7, 0.3, 0.2], "specular": [0.3, 0.3, 0.3], "shininess": 12}}
    ]
}"#;

/// The base scene with `edits` (text replacements) applied.
fn scene(edits: &[(&str, &str)]) -> Scene {
    let mut text = BASE.to_string();
    for (from, to) in edits {
        assert!(text.contains(from), "{from}");
        text = text.replacen(from, to, 1);
    }
    file::parse(&text).unwrap()
}

fn room() -> Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/scenes/room.json");
    let mut s = haze_scene::load(std::path::Path::new(path)).unwrap();
    s.camera = s.camera.with_size(40, 30).unwrap();
    s
}

/// Compares the GPU image with the CPU's (module docs).
fn compare(name: &str, scene: &Scene) -> Agreement {
    compare_within(name, scene, REL)
}

/// [`compare`] with the relative tolerance `rel`.
fn compare_within(name: &str, scene: &Scene, rel: f64) -> Agreement {
    let lim = Limits::default();
    let cpu = render(scene, analytic(), &lim, &|_| {});
    let gpu: Image = renderer().render(context(), scene, &lim).unwrap();
    assert_agree(name, &gpu, &cpu, Tolerance::new(rel, FLOOR, OUTLIERS))
}

#[test]
fn gpu_matches_the_cpu_on_every_case() {
    let cases: Vec<(&str, Scene)> = vec![
        ("room", room()),
        ("base", scene(&[])),
        (
            "coloured medium, suns and sky",
            scene(&[
                ("\"sigma_t\": 0.25", "\"sigma_t\": [0.2, 0.3, 0.45]"),
                ("\"environment\": [0.1, 0.12, 0.15]", "\"environment\": \"sky\", \"environment_distance\": 40"),
                (
                    "\"lights\": [",
                    "\"lights\": [{\"type\": \"sun\", \"direction\": [0.3, -0.4, 0.8], \"radiance\": [2000, 1900, 1700], \"angle\": 0.02},
                     {\"type\": \"sun\", \"direction\": [-0.6, 0.2, 0.3], \"radiance\": [0.5, 0.4, 0.3], \"angle\": 0},",
                ),
            ]),
        ),
        ("nearly clear (σt 1e-6)", scene(&[("\"sigma_t\": 0.25", "\"sigma_t\": 1e-6")])),
        (
            "environment at 1e35, beyond f32",
            scene(&[("[0.1, 0.12, 0.15]", "\"sky\", \"environment_distance\": 1e35")]),
        ),
        ("clear (σt 0), sky at ∞", scene(&[("\"sigma_t\": 0.25", "\"sigma_t\": 0"), ("[0.1, 0.12, 0.15]", "\"sky\"")])),
        (
            "dense (σt 3), eye close to the sphere",
            scene(&[
                ("\"sigma_t\": 0.25", "\"sigma_t\": 3"),
                ("\"eye\": [0, -6, 1.6]", "\"eye\": [0, -1.2, 1.2]"),
            ]),
        ),
        (
            "eye inside a sphere with a light",
            scene(&[(
                "\"surfaces\": [",
                "\"surfaces\": [{\"type\": \"sphere\", \"center\": [0, -5, 1.5], \"radius\": 2.5, \"material\": {\"diffuse\": [0.5, 0.5, 0.5]}},",
            ), ("[-1.2, -0.5, 1.8]", "[0.5, -4.5, 2]")]),
        ),
        ("light at the eye", scene(&[("[-1.2, -0.5, 1.8]", "[0, -6, 1.6]")])),
        (
            "light in the middle of the view",
            // The center pixel of a 33 × 25 image looks at the light: γ = 0, the model's
            // γ_min holds.
            scene(&[
                ("[-1.2, -0.5, 1.8]", "[0, -3, 1.2]"),
                ("\"width\": 32, \"height\": 24", "\"width\": 33, \"height\": 25"),
            ]),
        ),
        (
            "grazing plane",
            scene(&[("\"eye\": [0, -6, 1.6], \"target\": [0, 0, 0.8]", "\"eye\": [0, -6, 0.02], \"target\": [0, 0, 0.01]")]),
        ),
        ("light 1e-3 above the floor", scene(&[("[1.5, 1.0, 0.6]", "[1.5, -1.0, 0.001]")])),
        ("light on the floor", scene(&[("[1.5, 1.0, 0.6]", "[1.5, -1.0, 0]")])),
    ];
    for (name, s) in &cases {
        compare(name, s);
    }
}

#[test]
fn a_missing_phong_table_is_refused() {
    let mut s = scene(&[]);
    s.surfaces[1].material.shininess = 7.0;
    let e = renderer()
        .render(context(), &s, &Limits::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("surfaces[1]: no G table for the Phong exponent 7"),
        "{e}"
    );
}

/// Meshes on the GPU against the CPU (same tolerance): a smooth low-poly sphere (vertex
/// normals, specular) and a faceted one (face normals) turned and placed by the scene
/// file, lit by the point lights and a sun whose shadow rays cross the meshes; and the
/// eye close to a mesh, most rays crossing the hierarchy's boxes near their edges.
#[test]
fn gpu_matches_the_cpu_with_meshes() {
    use haze_scene::mesh::model;
    let dir = tempfile::tempdir().unwrap();
    let smooth = model::uv_sphere([0.0, 0.0, 0.0], 0.6, 8, [0.7, 0.3, 0.2]);
    let mut faceted = model::uv_sphere([0.0, 0.0, 0.0], 0.5, 5, [0.2, 0.5, 0.7]);
    faceted.normals = None;
    std::fs::write(dir.path().join("smooth.glb"), model::glb(&smooth)).unwrap();
    std::fs::write(dir.path().join("faceted.glb"), model::glb(&faceted)).unwrap();
    let meshes = r#""surfaces": [
        {"type": "mesh", "path": "smooth.glb", "transform": {"translate": [-0.6, 0.4, 0.6]},
         "material": {"diffuse": [0.7, 0.3, 0.2], "specular": [0.3, 0.3, 0.3], "shininess": 12}},
        {"type": "mesh", "path": "faceted.glb",
         "transform": {"translate": [0.8, -0.3, 0.5], "rotate": [1, 1, 0, 35], "scale": [1, 1, 1.4]}},"#;
    let load = |edits: &[(&str, &str)]| {
        let mut text = BASE.replacen("\"surfaces\": [", meshes, 1);
        for (from, to) in edits {
            assert!(text.contains(from), "{from}");
            text = text.replacen(from, to, 1);
        }
        let path = dir.path().join("scene.json");
        std::fs::write(&path, text).unwrap();
        haze_scene::load(&path).unwrap()
    };
    let sun = (
        "\"lights\": [",
        "\"lights\": [{\"type\": \"sun\", \"direction\": [0.4, -0.3, 0.8], \"radiance\": [0.8, 0.8, 0.7], \"angle\": 0},",
    );
    let cases = [
        ("meshes", load(&[sun])),
        (
            "eye close to a mesh",
            load(&[sun, ("\"eye\": [0, -6, 1.6]", "\"eye\": [0.5, -1.1, 0.9]")]),
        ),
    ];
    for (name, s) in &cases {
        compare(name, s);
    }
}

/// The environment's light through the medium (`envglow`, SH of order 16) on the GPU
/// against the CPU (same tolerance): a lat-long map glowing through the medium (its
/// distance 12), lighting the Lambert plane and the Phong sphere, with and without the
/// point lights; a constant environment close by in a dense medium; the sky far away in a
/// nearly clear one. Tolerance 3·10⁻³: the shader's `f32` sums of 256 SH terms per
/// channel, whose magnitudes add up to ~10–100× the result next to a bright texel (the
/// ringing cancels), lose ~`256·6·10⁻⁸·100 ≈ 2·10⁻³` (measured: 1.9·10⁻³ at worst).
#[test]
fn gpu_matches_the_cpu_with_environment_glow() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (16, 8);
    let pixels = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let spot = if (x, y) == (5.0, 2.0) { 30.0 } else { 0.0 };
            [
                0.2 + 0.05 * x + spot,
                0.3 + 0.1 * y,
                0.6 - 0.05 * y + 0.5 * spot,
            ]
        })
        .collect();
    haze_view::Image {
        width: w,
        height: h,
        pixels,
    }
    .write_exr(&dir.path().join("env.exr"))
    .unwrap();
    let text = BASE.replacen(
        "\"environment\": [0.1, 0.12, 0.15]",
        "\"environment\": \"env.exr\", \"environment_distance\": 12",
        1,
    );
    let map = file::parse_in(&text, dir.path()).unwrap();
    let mut unlit = map.clone();
    unlit.lights.clear();
    let cases = [
        ("environment map glowing", map),
        ("environment map glowing, no lights", unlit),
        (
            "constant environment at 5, dense",
            scene(&[
                (
                    "[0.1, 0.12, 0.15]",
                    "[0.5, 0.4, 0.3], \"environment_distance\": 5",
                ),
                ("\"sigma_t\": 0.25", "\"sigma_t\": [1.2, 0.8, 0.5]"),
            ]),
        ),
        (
            "sky at 1e4, nearly clear",
            scene(&[
                (
                    "[0.1, 0.12, 0.15]",
                    "\"sky\", \"environment_distance\": 1e4",
                ),
                ("\"sigma_t\": 0.25", "\"sigma_t\": 1e-5"),
            ]),
        ),
    ];
    for (name, s) in &cases {
        compare_within(name, s, 3e-3);
    }
}

/// The environment's SH projection and glow are kept between frames
/// (`GpuRenderer::env_builds`): a camera move and a moved light project nothing again and
/// give a fresh renderer's picture to the bit; a medium edit rebuilds the glow from the
/// kept projection; another environment projects again.
#[test]
fn the_environment_is_projected_once_across_camera_moves() {
    let ctx = context();
    let lim = Limits::default();
    let sky = scene(&[("[0.1, 0.12, 0.15]", "\"sky\", \"environment_distance\": 12")]);
    let r = GpuRenderer::new(ctx, analytic()).unwrap();
    let first = r.render(ctx, &sky, &lim).unwrap();
    assert_eq!(r.env_builds(), (1, 1));
    let mut moved = sky.clone();
    moved.camera = haze_scene::Camera::new(
        [2.5, -5.0, 2.2],
        [0.0, 0.0, 0.8],
        [0.0, 0.0, 1.0],
        55.0,
        32,
        24,
    )
    .unwrap();
    if let haze_scene::Light::Point { position, .. } = &mut moved.lights[0] {
        position[0] += 0.5;
    }
    let a = r.render_rasterized(ctx, &moved, &lim).unwrap();
    assert_eq!(r.env_builds(), (1, 1));
    assert_ne!(a.pixels, first.pixels);
    let fresh = GpuRenderer::new(ctx, analytic()).unwrap();
    assert_eq!(
        a.pixels,
        fresh.render_rasterized(ctx, &moved, &lim).unwrap().pixels
    );
    let mut thick = moved.clone();
    thick.medium.sigma_t = [0.4; 3];
    let b = r.render(ctx, &thick, &lim).unwrap();
    assert_eq!(r.env_builds(), (1, 2));
    let fresh = GpuRenderer::new(ctx, analytic()).unwrap();
    assert_eq!(b.pixels, fresh.render(ctx, &thick, &lim).unwrap().pixels);
    thick.environment = haze_scene::Environment::Constant([0.2, 0.3, 0.4]);
    r.render(ctx, &thick, &lim).unwrap();
    assert_eq!(r.env_builds(), (2, 3));
}
